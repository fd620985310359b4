#!/usr/bin/env bash
# He et al.'s mass-spring experiment reproduced with `organsim springs`
# (results and discussion in docs/springs.md):
#   1. the paper's settings as printed: 225- and 625-point grids (15x15, 25x25),
#      explicit Euler, midpoint and RK4, fixed (all) and dynamic region, 100 steps
#      of dt = 0.01 s, 5 N at the centre vertex: the explicit integrators blow up
#      and the blow-up detection stops them (implicit Euler as the reference);
#   2. the same at a stable step (STABLE_DT): compute time per step and the force
#      point's displacement after the 100 steps and at the paper's simulated time
#      (1 s); one PNG per grid of the displacement over the steps per integrator;
#   3. the largest stable dt per integrator on both grids, by bisection over --dt,
#      each run covering the same simulated time;
#   4. readings of the paper's damping under which dt = 0.01 is stable, and 5. the
#      printed spring damping scaled, with explicit Euler at dt = 0.01.
# Prints Markdown tables on stdout; writes the PNGs to OUT_DIR (default docs/springs).
#
# Usage: bash tools/experiments/springs_paper.sh [OUT_DIR]
# Needs build/tools/organsim (ninja -C build organsim), awk, and xvfb-run for the
# plots (VTK renders off screen through X). About 5 minutes on 2 cores.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
organsim=${ORGANSIM:-$repo/build/tools/organsim}
out_dir=${1:-$repo/docs/springs}
[[ -x $organsim ]] || { echo "springs_paper.sh: $organsim is missing: ninja -C build organsim" >&2; exit 1; }
command -v xvfb-run >/dev/null || { echo "springs_paper.sh: xvfb-run is missing (apt-get install xvfb xauth)" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out_dir"

# The paper gives no lengths. 10 mm between grid points makes the 15x15 grid a
# 14 cm square and the 25x25 grid a 24 cm one: organ-sized patches (a liver is
# about 15-25 cm across), and the body springs' anchors 1 cm below the surface.
SPACING=10
# The stable step: 0.5 ms is below every explicit integrator's linear stability
# limit on both grids under the 5 N load (the smallest, explicit Euler's, is
# 0.9 ms: part 3), with a margin of 1.8; the 100 steps then cover 50 ms.
STABLE_DT=0.0005
# Part 3: a dt is stable when a run of SETTLE_S simulated seconds never blows up and
# ends settled (kinetic energy in the last second at most 1e-9 J and not growing);
# "survives" asks only for no blow-up within the paper's simulated second.
SETTLE_S=30
GRIDS="15x15 25x25"
# Every other setting is organsim springs' default, which is the paper's: mass 0.01 kg,
# g 9.8, k 2/2/1.2 N/m, c 0.4/0.4/0.24 N s/m, body springs 2x, 5 N along -z at the
# centre vertex, threshold 0.001 m, the border fixed.
PAPER="--spacing $SPACING --quiet"

# springs NAME ARGS...: one run; JSON in $work/NAME.json, trace in $work/NAME.csv.
springs() {
  local name=$1
  shift
  "$organsim" springs $PAPER "$@" --json --trace "$work/$name.csv" >"$work/$name.json" 2>"$work/$name.err"
}
# field NAME KEY: a scalar of NAME's JSON.
field() { grep -o "\"$2\":[^,}]*" "$work/$1.json" | head -1 | cut -d: -f2; }
# dz_mm NAME [STEP]: the force point's dz (mm) after STEP (default: the last step taken).
dz_mm() { awk -F, -v s="${2:-0}" 'NR > 1 && (s == 0 || $1 == s) { d = $5 } END { printf "%.1f", d * 1000 }' "$work/$1.csv"; }
# blew_up NAME: "step S" when NAME blew up, else "-".
blew_up() { if [[ $(field "$1" stable) == true ]]; then echo "-"; else echo "step $(($(field "$1" steps) + 1))"; fi; }
# settled NAME SECONDS: NAME ran all its steps, and its kinetic energy in the last
# second is at most 1e-9 J and at most 1.1 x that of the second before.
settled() {
  [[ $(field "$1" stable) == true ]] || return 1
  awk -F, -v T="$2" 'NR > 1 { if ($2 > T - 1 + 1e-9) { if ($7 > b) b = $7 } else if ($2 > T - 2 + 1e-9) { if ($7 > a) a = $7 } }
    END { exit !(b <= 1e-9 && b <= 1.1 * a) }' "$work/$1.csv"
}
# decays NAME SECONDS: as settled, without the 1e-9 J bound (bounded and not growing).
decays() {
  [[ $(field "$1" stable) == true ]] || return 1
  awk -F, -v T="$2" 'NR > 1 { if ($2 > T - 1 + 1e-9) { if ($7 > b) b = $7 } else if ($2 > T - 2 + 1e-9) { if ($7 > a) a = $7 } }
    END { exit !(b <= 1.1 * a) }' "$work/$1.csv"
}
steps_for() { awk -v T="$1" -v dt="$2" 'BEGIN { printf "%d", T / dt + 0.5 }'; }
# merge OUT COLUMN LABEL=NAME... : one CSV with `step` and, per LABEL, column
# COLUMN (m, written in mm) of the trace of run NAME; blank after a run stopped.
merge() {
  local out=$1 column=$2 pair labels=() files=()
  shift 2
  for pair in "$@"; do
    labels+=("${pair%%=*}")
    files+=("$work/${pair#*=}.csv")
  done
  awk -F, -v c="$column" -v names="${labels[*]}" '
    FNR == 1 { k++; next }
    { v[k, $1] = sprintf("%.6g", $c * 1000); if ($1 + 0 > last) last = $1 + 0 }
    END {
      n = split(names, label, " "); printf "step"; for (i = 1; i <= n; i++) printf ",%s", label[i]; print ""
      for (s = 1; s <= last; s++) { printf "%d", s; for (i = 1; i <= n; i++) printf ",%s", v[i, s]; print "" }
    }' "${files[@]}" >"$out"
}
plot() { xvfb-run -a "$organsim" plot "$@" --quiet >/dev/null; }

echo "# He et al.'s mass-spring experiment, reproduced"
echo
echo "organsim springs, grid spacing $SPACING mm, 5 N along -z at the centre vertex, mass 0.01 kg, g 9.8 m/s^2,"
echo "k 2/2/1.2 N/m, c 0.4/0.4/0.24 N s/m, body springs 2x, threshold 0.001 m; $(uname -m), $(nproc) cores,"
echo "$(lscpu | sed -n 's/^Model name: *//p' | head -1); $("$organsim" --version)."

# 1. The paper's dt.
echo
echo "## 1. The paper's settings: dt = 0.01 s, 100 steps"
echo
echo "| grid | integrator | region | steps done | blew up at | us/step | compute for the steps done (ms) | force point dz at the last good step (mm) |"
echo "|---|---|---|---|---|---|---|---|"
for grid in $GRIDS; do
  for integrator in euler midpoint rk4 implicit; do
    for region in all dynamic; do
      name=paper_${grid}_${integrator}_$region
      springs "$name" --grid "$grid" --integrator "$integrator" --region "$region" --dt 0.01 --steps 100
      us=$(field "$name" time_per_step_us)
      steps=$(field "$name" steps)
      printf "| %s | %s | %s | %s | %s | %.1f | %.3f | %s |\n" "$grid" "$integrator" "$region" "$steps" \
        "$(blew_up "$name")" "$us" "$(awk -v u="$us" -v s="$steps" 'BEGIN { print u * s / 1000 }')" "$(dz_mm "$name")"
    done
  done
  merge "$work/paper_$grid.csv" 5 euler="paper_${grid}_euler_all" midpoint="paper_${grid}_midpoint_all" \
    rk4="paper_${grid}_rk4_all" implicit="paper_${grid}_implicit_all"
  head -21 "$work/paper_$grid.csv" >"$work/paper_${grid}_20.csv"
  caught=$(for integrator in euler midpoint rk4; do blew_up "paper_${grid}_${integrator}_all"; done | sort -u)
  [[ $(echo "$caught" | wc -l) == 1 && $caught != - ]] && caught="blow up at $caught" || caught="until their blow-up"
  plot "$work/paper_${grid}_20.csv" --x step --y euler,midpoint,rk4,implicit -o "$out_dir/grid${grid}_dt0.01.png" \
    --title "$grid grid, dt 0.01 s (the paper's): explicit integrators $caught" \
    --y-label "force point displacement dz (mm)"
done

# 2. A stable dt.
one_second=$(steps_for 1 "$STABLE_DT")
echo
echo "## 2. A stable step: dt = $STABLE_DT s, 100 steps ($(awk -v dt=$STABLE_DT 'BEGIN { print 100 * dt * 1000 }') ms), and on to 1 s ($one_second steps)"
echo
echo "| grid | integrator | region | us/step | 100 steps (ms) | dz after 100 steps (mm) | active vertices at steps 1 / 100 | us/step over 1 s | dz at 1 s (mm) | active at 1 s |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for grid in $GRIDS; do
  for integrator in euler midpoint rk4 symplectic implicit; do
    for region in all dynamic; do
      name=stable_${grid}_${integrator}_$region
      springs "$name" --grid "$grid" --integrator "$integrator" --region "$region" --dt "$STABLE_DT" --steps 100
      long=long_${grid}_${integrator}_$region
      springs "$long" --grid "$grid" --integrator "$integrator" --region "$region" --dt "$STABLE_DT" --steps "$one_second"
      us=$(field "$name" time_per_step_us)
      active=$(grep -o '"active_vertices":\[[0-9,]*' "$work/$name.json" | cut -d'[' -f2 | awk -F, '{ print $1 " / " $NF }')
      printf "| %s | %s | %s | %.1f | %.2f | %s | %s | %.1f | %s | %s |\n" "$grid" "$integrator" "$region" "$us" \
        "$(awk -v u="$us" 'BEGIN { print u * 100 / 1000 }')" "$(dz_mm "$name")" "$active" \
        "$(field "$long" time_per_step_us)" "$(dz_mm "$long")" \
        "$(awk -F, 'END { print $6 }' "$work/$long.csv")"
      [[ $(field "$name" stable) == true && $(field "$long" stable) == true ]] ||
        echo "springs_paper.sh: warning: $name or $long blew up" >&2
    done
  done
  merge "$work/stable_$grid.csv" 5 euler="stable_${grid}_euler_all" midpoint="stable_${grid}_midpoint_all" \
    rk4="stable_${grid}_rk4_all" implicit="stable_${grid}_implicit_all"
  plot "$work/stable_$grid.csv" --x step --y euler,midpoint,rk4,implicit -o "$out_dir/grid${grid}_dt$STABLE_DT.png" \
    --title "$grid grid, dt $STABLE_DT s, 5 N at the centre: force point displacement per integrator" \
    --y-label "force point displacement dz (mm)"
done

# 3. The largest stable dt.
# bisect KIND GRID INTEGRATOR ARGS...: the largest dt (ms) that passes KIND
# (settles: SETTLE_S seconds, settled; survives: 1 s without a blow-up), to 1 %.
bisect() {
  local kind=$1 grid=$2 integrator=$3
  shift 3
  local low=0.0002 high=0.012 mid seconds=$SETTLE_S name=bisect
  [[ $kind == survives ]] && seconds=1
  while awk -v l=$low -v h=$high 'BEGIN { exit !(h - l > 0.005 * l) }'; do
    mid=$(awk -v l=$low -v h=$high 'BEGIN { printf "%.7f", (l + h) / 2 }')
    springs $name --grid "$grid" --integrator "$integrator" --dt "$mid" --steps "$(steps_for "$seconds" "$mid")" "$@"
    if [[ $kind == survives && $(field $name stable) == true ]] || { [[ $kind == settles ]] && settled $name "$seconds"; }; then
      low=$mid
    else
      high=$mid
    fi
  done
  awk -v l=$low 'BEGIN { printf "%.2f", l * 1000 }'
}
echo
echo "## 3. Largest stable dt (ms), by bisection over --dt to 0.5 %"
echo
echo "Settles: $SETTLE_S s of simulated time without a blow-up, ending at rest (kinetic energy in the last"
echo "second <= 1e-9 J and not growing). Survives 1 s: no blow-up within the paper's simulated second (100 x 0.01 s)."
echo
echo "| grid | integrator | 5 N: settles | 5 N: survives 1 s | gravity only: settles |"
echo "|---|---|---|---|---|"
for grid in $GRIDS; do
  for integrator in euler midpoint rk4 symplectic; do
    printf "| %s | %s | %s | %s | %s |\n" "$grid" "$integrator" "$(bisect settles "$grid" "$integrator")" \
      "$(bisect survives "$grid" "$integrator")" "$(bisect settles "$grid" "$integrator" --force 0,0,0)"
  done
done
echo
echo "Implicit Euler (linearly implicit, unconditionally stable for the linearized model):"
echo
echo "| grid | dt (s) | steps ($SETTLE_S s) | settles | dz at the end (mm) |"
echo "|---|---|---|---|---|"
for grid in $GRIDS; do
  for dt in 0.01 0.05; do
    name=implicit_${grid}_$dt
    springs "$name" --grid "$grid" --integrator implicit --dt "$dt" --steps "$(steps_for "$SETTLE_S" "$dt")"
    printf "| %s | %s | %s | %s | %s |\n" "$grid" "$dt" "$(field "$name" steps)" \
      "$(settled "$name" "$SETTLE_S" && echo yes || echo no)" "$(dz_mm "$name")"
  done
done

# 4. Readings of the paper's damping at dt = 0.01.
echo
echo "## 4. Readings of the paper's damping at dt = 0.01 s (15x15 and 25x25, 5 N)"
echo
echo "Each cell: the paper's 100 steps (blow-up step, or dz after 100 steps in mm) / $SETTLE_S s: settles, decays"
echo "(bounded, not growing, not yet at rest), grows, or the step at which it blew up."
echo
echo "| reading | options | grid | euler | midpoint | rk4 | symplectic |"
echo "|---|---|---|---|---|---|---|"
readings=(
  "as printed: spring damping, N s/m|--damping 0.4,0.4,0.24"
  "per unit mass: c x m|--damping 0.004,0.004,0.0024"
  "fraction of critical: c x 2 sqrt(k m)|--damping 0.11314,0.11314,0.05258"
  "point damping -c v_i (no spring damping)|--damping 0,0,0 --point-damping 0.4"
)
for reading in "${readings[@]}"; do
  label=${reading%%|*}
  options=${reading#*|}
  for grid in $GRIDS; do
    row="| $label | \`$options\` | $grid |"
    for integrator in euler midpoint rk4 symplectic; do
      springs short --grid "$grid" --integrator "$integrator" --dt 0.01 --steps 100 $options
      springs long --grid "$grid" --integrator "$integrator" --dt 0.01 --steps "$(steps_for "$SETTLE_S" 0.01)" $options
      if [[ $(field short stable) == true ]]; then first="$(dz_mm short)"; else first="blew up at $(blew_up short)"; fi
      if [[ $(field long stable) != true ]]; then second="blew up at $(blew_up long)"
      elif settled long "$SETTLE_S"; then second=settles
      elif decays long "$SETTLE_S"; then second=decays
      else second=grows; fi
      row+=" $first / $second |"
    done
    echo "$row"
  done
done

# 5. Explicit Euler with the spring damping scaled.
echo
echo "## 5. Explicit Euler at dt = 0.01 s with the printed spring damping scaled by s (15x15)"
echo
echo "Steps completed of $(steps_for "$SETTLE_S" 0.01) ($SETTLE_S s); 100 or more completes the paper's experiment."
echo
scales="0.02 0.05 0.1 0.2 0.3 0.4 0.5 0.6 0.8 1"
echo "| load | $(echo $scales | sed 's/ / | /g') |"
echo "|---|$(for s in $scales; do printf -- '---|'; done)"
for force in 0,0,-5 0,0,0; do
  row="| $([[ $force == 0,0,0 ]] && echo "gravity only" || echo "5 N") |"
  for scale in $scales; do
    springs scan --grid 15x15 --integrator euler --dt 0.01 --steps "$(steps_for "$SETTLE_S" 0.01)" --force "$force" \
      --damping "$(awk -v s="$scale" 'BEGIN { printf "%g,%g,%g", 0.4 * s, 0.4 * s, 0.24 * s }')"
    row+=" $(field scan steps) |"
  done
  echo "$row"
done
echo
echo "Plots: $(cd "$out_dir" && ls grid*.png | tr '\n' ' ')in ${out_dir#"$repo"/}."
