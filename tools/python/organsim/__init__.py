"""organsim: patient-specific organ models from CT, and their real-time deformation.

    import organsim
    report = organsim.bake("ct.nii.gz", "liver.organ", label="liver_mask.nii.gz")
    model = organsim.load("liver.organ")
    beam = organsim.MultiBeam(model, max_tools=1)
    beam.attach(0, model.surface_vertices[100])
    force = beam.force(0, [0.0, 0.0, -0.005])          # N, for a 5 mm press

Units are SI (m, N, Pa, s) everywhere, as inside the model file; coordinates are
in the CT's patient frame (LPS). Errors raise organsim.Error (a RuntimeError)
with the same one-line messages as the organsim program, or ValueError /
IndexError for arguments out of range.
"""
import json
import math
import os

from ._organsim import BakeOptions, Error, Model, MultiBeam, Simulation, __version__, beam_section_fields
from ._organsim import _bake, _load, _replay

__all__ = ["BakeOptions", "Error", "Model", "MultiBeam", "Simulation", "__version__", "bake", "bake_options",
           "bake_with", "beam_section_fields", "load", "replay"]


def load(path):
    """Reads a .organ model file (checked: a bad file raises organsim.Error).

    Its arrays (surface_vertices, surface_triangles, volume_vertices, tetrahedra,
    fixed_points, beam_sections) are read-only numpy views of the model, in m."""
    return _load(os.fspath(path))


def replay(model, session, kind=None, tip_radius=2.5e-3, **settings):
    """`organsim replay --fast` of a session file through the real-time engine.

    kind: a deformation model's name (the default: the program's); tip_radius
    (m) is the tools' hemispherical end, as `--tip-radius` (mm) is the
    program's; a session file's tip lines override it per tool. settings: the
    models' settings by name, as organsim.Simulation takes them (merge="sum",
    fixed_radius=0.03, volume_springs=True, ...: lengths in m).
    Returns a dict: times (R,) s, forces (tools, R, 3) N as sent to each device,
    in_contact (tools, R), duration s. Bit-identical to the program's forces."""
    if kind is None:
        return _replay(model, os.fspath(session), tip_radius=tip_radius, **settings)
    return _replay(model, os.fspath(session), kind, tip_radius, **settings)


def _number(kind):
    def convert(value):
        if isinstance(value, bool) or not isinstance(value, (int, float)) and not hasattr(value, "item"):
            raise TypeError(f"expected a number, got {value!r}")
        return kind(value.item() if hasattr(value, "item") else value)
    return convert


def _point(value):
    """X, Y, Z in mm: three finite numbers."""
    point = tuple(float(v) for v in (value.tolist() if hasattr(value, "tolist") else value))
    if len(point) != 3 or not all(math.isfinite(v) for v in point):
        raise ValueError(f"expected X,Y,Z (three finite numbers, mm), got {value!r}")
    return point


def _voxel(value):
    """I, J, K: three whole voxel indices."""
    point = _point(value)
    if any(v != int(v) for v in point):
        raise ValueError(f"expected I,J,K (three whole voxel indices), got {value!r}")
    return tuple(int(v) for v in point)


def _points(value):
    """One point, or a list of points (a repeated option)."""
    items = value.tolist() if hasattr(value, "tolist") else value
    return list(items) if items and isinstance(items[0], (list, tuple)) else [items]


def _pair(value):
    pair = tuple(float(v) for v in value)
    if len(pair) != 2:
        raise ValueError(f"expected two numbers, got {value!r}")
    return pair


def _setter(path, convert):
    """Sets options.<path> (dotted) to convert(value)."""
    *parents, field = path.split(".")

    def set_field(options, value):
        target = options
        for parent in parents:
            target = getattr(target, parent)
        setattr(target, field, convert(value))
    return set_field


def _adder(method, convert):
    def add(options, value):
        for point in _points(value):
            getattr(options.seeded, method)(convert(point))
    return add


def _set_closing(options, value):
    options.label_closing_radius_mm = options.seeded.closing_radius_mm = _number(float)(value)


def _set_window_sigmas(options, value):
    options.seeded.window_sigmas_below, options.seeded.window_sigmas_above = _pair(value)


def _set_no_beam_tables(options, value):
    if value is not True:
        raise TypeError("a flag: pass True")
    options.beam_tables = False


# `organsim bake --help`'s options, each setting its field of BakeOptions (the
# pipeline's own options type, bound field for field): what the program does
# with the same option after parsing it.
_BAKE_OPTIONS = {
    "series": _setter("series_uid", str),
    "label": _setter("label_path", os.fspath),
    "label_value": _setter("label_value", _number(int)),
    "seed": _adder("add_seed", _point),
    "seed_voxel": _adder("add_seed_voxel", _voxel),
    "background_seed": _adder("add_background_seed", _point),
    "background_seed_voxel": _adder("add_background_seed_voxel", _voxel),
    "hu_window": _setter("seeded.hu_window", _pair),
    "window_sigmas": _set_window_sigmas,
    "seed_radius": _setter("seeded.seed_radius_mm", _number(float)),
    "opening": _setter("seeded.opening_radius_mm", _number(float)),
    "reach": _setter("seeded.reach_mm", _number(float)),
    "lesion_radius": _setter("seeded.lesion_radius_mm", _number(float)),
    "smoothing_iterations": _setter("seeded.smoothing_iterations", _number(int)),
    "working_spacing": _setter("seeded.working_spacing_mm", _number(float)),
    "reference": _setter("reference_label_path", os.fspath),
    "reference_value": _setter("reference_label_value", _number(int)),
    "closing": _set_closing,
    "fixed_point": _setter("fixed_point_mm", _point),
    "fixed_point_voxel": _setter("fixed_point_voxel", _voxel),
    "surface_vertices": _setter("surface.target_vertices", _number(int)),
    "tet_size": _setter("tetrahedra.tet_size_mm", _number(float)),
    "facet_distance": _setter("tetrahedra.facet_distance_mm", _number(float)),
    "stations": _setter("beams.stations", _number(int)),
    "no_beam_tables": _set_no_beam_tables,
    "section_samples": _setter("beams.samples_per_side", _number(int)),
    "threads": _setter("beams.threads", _number(int)),
    "young_modulus": _setter("material.young_modulus", _number(float)),
    "poisson_ratio": _setter("material.poisson_ratio", _number(float)),
    "density": _setter("material.density", _number(float)),
    "alpha": _setter("material.attenuation_alpha", _number(float)),
    "beta": _setter("material.attenuation_beta", _number(float)),
    "intermediates": _setter("intermediates_dir", os.fspath),
}


def bake_options(ct, output, **options):
    """The BakeOptions of `organsim bake CT -o OUTPUT [options]` (see bake())."""
    baked = BakeOptions()
    baked.ct_path = os.fspath(ct)
    baked.output_path = os.fspath(output)
    for name, value in options.items():
        if name not in _BAKE_OPTIONS:
            raise ValueError(f"bake: no option --{name.replace('_', '-')} (organsim bake --help lists them)")
        if value is None or value is False:
            continue
        try:
            _BAKE_OPTIONS[name](baked, value)
        except (TypeError, ValueError) as error:
            raise ValueError(f"bake: --{name.replace('_', '-')}: {error}") from None
    return baked


def bake(ct, output, **options):
    """Bakes a CT into a model file, as `organsim bake CT -o OUTPUT [options]`.

    Every option of `organsim bake --help` is a keyword argument, dashes written as
    underscores: label="mask.nii.gz", seed=(x, y, z) in mm (or a list of such
    points for several seeds), fixed_point=(x, y, z), tet_size=4.0, stations=20,
    young_modulus=5000, no_beam_tables=True, ... Coordinates are in mm here, as on
    the command line and in 3D Slicer. The keywords set the fields of a BakeOptions
    (the pipeline's options: bake_options() returns them), which the pipeline bakes
    directly. Returns the report (`bake --json`) as a dict.
    """
    return bake_with(bake_options(ct, output, **options))


def bake_with(options):
    """Bakes with a BakeOptions (its output_path set); returns the report as bake() does."""
    return json.loads(_bake(options))
