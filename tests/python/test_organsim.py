"""The Python module organsim: models as numpy arrays without copies, bake with
the command line's options and results, the deformation models, replay, and
errors with the program's messages."""
import json
import pathlib
import re

import numpy as np
import pytest

import organsim
from conftest import QUICK_BAKE, SAMPLES, run_program

REPOSITORY = pathlib.Path(__file__).parents[2]


def test_bake_gives_the_programs_model_and_report(phantom, tmp_path):
    path, report = phantom
    # The same bake through the program: the same bytes, the same report.
    other = tmp_path / "cli.organ"
    code, out, err = run_program("bake", SAMPLES / "phantom_ct.nii.gz", "-o", other, "--seed", "-65,5,0",
                                 "--surface-vertices", 800, "--tet-size", 12, "--stations", 8, "--section-samples",
                                 32, "--json", "--quiet")
    assert code == 0, err
    assert other.read_bytes() == path.read_bytes()
    cli_report = json.loads(out)
    for key in ("surface", "tetrahedra", "fixed_point"):
        assert report[key] == cli_report[key], key
    assert report["segmentation"]["method"] == cli_report["segmentation"]["method"]
    assert report["surface"]["vertices"] > 0


def test_load_gives_read_only_views_of_the_model(phantom):
    path, report = phantom
    model = organsim.load(path)
    vertices = model.surface_vertices
    assert vertices.dtype == np.float64 and vertices.shape == (report["surface"]["vertices"], 3)
    assert model.surface_triangles.dtype == np.uint32 and model.surface_triangles.shape[1] == 3
    assert model.tetrahedra.shape[1] == 4 and model.volume_vertices.shape[1] == 3
    assert model.tetrahedra.max() < len(model.volume_vertices)
    # No copy: two reads share the model's memory, and neither can change it.
    assert np.shares_memory(vertices, model.surface_vertices)
    assert not vertices.flags.writeable
    with pytest.raises(ValueError):
        vertices[0, 0] = 1.0
    # Metres, LPS: the phantom liver spans about 20 cm.
    extent = vertices.max(axis=0) - vertices.min(axis=0)
    assert 0.1 < extent.max() < 0.4
    sections = model.beam_sections
    assert sections.shape == (len(vertices), 8, len(organsim.beam_section_fields))
    assert (sections[:, :, 0] >= 0).all() and sections[:, :, 0].max() > 0  # areas, m²
    assert model.material["young_modulus_pa"] == 5000.0
    assert model.provenance["coordinate_frame"] == "LPS"
    # The model outlives the name it was loaded under: the views keep it alive.
    del model
    assert np.isfinite(sections).all() and np.isfinite(vertices).all()


def test_multibeam_force_and_deformation(phantom):
    model = organsim.load(phantom[0])
    beam = organsim.MultiBeam(model, max_tools=2)
    top = model.surface_vertices[np.argmax(model.surface_vertices[:, 2])]
    beam.attach(0, top)
    press = np.array([0.0, 0.0, -0.005])
    force = beam.force(0, press)
    np.testing.assert_allclose(force, -beam.stiffness(0) @ press, rtol=1e-12)
    np.testing.assert_allclose(beam.force(0, 2 * press), 2 * force, rtol=1e-12)  # linear
    assert force[2] > 0  # pushed down, the organ pushes back up
    positions, normals = beam.deform(np.vstack([press, np.zeros(3)]))  # tool 1 detached: its row ignored
    assert positions.shape == model.surface_vertices.shape
    nearest = np.argmin(np.linalg.norm(model.surface_vertices - beam.action_point(0), axis=1))
    moved = positions[nearest] - model.surface_vertices[nearest]
    assert moved[2] == pytest.approx(-0.005, abs=0.001)  # the press point follows the tool
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, rtol=1e-6)  # normalized in single precision
    with pytest.raises(IndexError):
        beam.attach(2, top)
    with pytest.raises(organsim.Error, match="no beam"):
        beam.force(1, press)


@pytest.mark.parametrize("kind", ["springs", "linear"])
def test_every_model_through_the_engines_interface(phantom, kind):
    model = organsim.load(phantom[0])
    simulation = organsim.Simulation(model, kind, tools=1, fixed_radius=0.03)
    top = model.surface_vertices[np.argmax(model.surface_vertices[:, 2])]
    contact = simulation.attach(0, top)
    assert contact["normal"][2] > 0.5
    press = [[0.0, 0.0, -0.003]]
    for _ in range(60 if kind == "springs" else 1):
        positions, _ = simulation.step(1 / 60, press)
    force = simulation.force(0, press[0])
    assert force[2] > 0
    assert np.abs(positions - model.surface_vertices).max() > 0.001
    with pytest.raises(ValueError):
        simulation.step(1 / 60, [[0.0, 0.0]])
    with pytest.raises(ValueError, match="unknown model"):
        organsim.Simulation(model, "fluid")


@pytest.mark.parametrize("kind", ["beam", "springs", "linear"])
def test_a_grasp_lifts_the_organ_and_it_pulls_back(phantom, kind):
    model = organsim.load(phantom[0])
    simulation = organsim.Simulation(model, kind, tools=1, fixed_radius=0.03)
    top_index = np.argmax(model.surface_vertices[:, 2])
    simulation.attach(0, model.surface_vertices[top_index])
    frames = 60 if kind == "springs" else 1
    for _ in range(frames):
        simulation.step(1 / 60, [[0.0, 0.0, -0.003]])  # pressed 3 mm in
    simulation.grasp(0)                                 # the jaws close on it
    lift = [[0.0, 0.0, 0.004]]                          # and lift it 4 mm above its rest
    for _ in range(frames):
        positions, _ = simulation.step(1 / 60, lift)
    assert simulation.force(0, lift[0])[2] < 0          # the organ pulls the tool back down
    assert positions[top_index, 2] - model.surface_vertices[top_index, 2] > 0.002
    simulation.grasp(0, False)
    simulation.detach(0)
    with pytest.raises(organsim.Error, match="touches nothing to grasp"):
        simulation.grasp(0)


def press_session(model, tmp_path):
    """A session file: one tool 3 mm into the top of the organ and out again."""
    top = model.surface_vertices[np.argmax(model.surface_vertices[:, 2])] * 1e3  # mm
    session = tmp_path / "press.session"
    lines = ["# organsim session 1"]
    for t, depth in [(0.0, -2.0), (0.3, 3.0), (0.6, 3.0), (0.9, -2.0)]:
        lines.append(f"{t:.3f},1,{top[0]:.3f},{top[1]:.3f},{top[2] - depth:.3f}")
    session.write_text("\n".join(lines) + "\n")
    return session


def test_replay_gives_the_programs_forces(phantom, tmp_path):
    path = phantom[0]
    model = organsim.load(path)
    session = press_session(model, tmp_path)
    result = organsim.replay(model, session)
    assert result["forces"].shape == (1, len(result["times"]), 3)
    assert result["in_contact"].any()
    assert result["forces"][0, :, 2].max() > 0
    # The program's replay --fast of the same session: the same forces, bit for bit.
    forces_csv = tmp_path / "forces.csv"
    code, _, err = run_program("replay", path, session, "--fast", "--forces", forces_csv, "--quiet")
    assert code == 0, err
    table = np.loadtxt(forces_csv, delimiter=",", skiprows=1)
    np.testing.assert_allclose(result["times"], table[:, 0], atol=1e-6)
    np.testing.assert_allclose(result["forces"][0], table[:, 2:5], rtol=1e-8, atol=1e-12)


def test_the_models_settings_are_the_programs_options_in_si(phantom, tmp_path):
    # Every model's setting is a keyword (its option's name with _ for -, lengths in m),
    # read by the model's own registered parameter: the program's forces with the same
    # settings (--merge sum --volume-springs --fixed-radius 30), bit for bit.
    path = phantom[0]
    model = organsim.load(path)
    session = press_session(model, tmp_path)
    for kind, settings, options in [("beam", {"merge": "sum"}, ["--merge", "sum"]),
                                    ("springs", {"volume_springs": True, "fixed_radius": 0.03},
                                     ["--volume-springs", "--fixed-radius", "30"])]:
        result = organsim.replay(model, session, kind, **settings)
        forces_csv = tmp_path / f"{kind}.csv"
        code, _, err = run_program("replay", path, session, "--model", kind, *options, "--fast", "--forces",
                                   forces_csv, "--quiet")
        assert code == 0, err
        table = np.loadtxt(forces_csv, delimiter=",", skiprows=1)
        assert np.abs(table[:, 2:5]).max() > 0
        np.testing.assert_allclose(result["forces"][0], table[:, 2:5], rtol=1e-8, atol=1e-12)
    with pytest.raises(ValueError, match="no model takes the setting 'stiffness'.*region_threshold"):
        organsim.Simulation(model, "springs", stiffness=3.0)
    with pytest.raises(ValueError, match="fixed_radius: the clamp's radius must be a positive length"):
        organsim.Simulation(model, "linear", fixed_radius=-0.01)
    assert "region_threshold" in organsim.Simulation.__init__.__doc__


def test_the_tip_radius_reaches_the_engine_as_the_programs_does(phantom, tmp_path):
    # With the bake's site compliances a tool of finite size gets the FEM
    # reference's site law for its radius, a point tool the springs' own
    # reaction: the 6 mm tip's force is not the point's (on this 12 mm mesh a
    # FEM model's tip holds what a point holds); each is the program's
    # --tip-radius, bit for bit.
    path = phantom[0]
    model = organsim.load(path)
    session = press_session(model, tmp_path)
    peaks = {}
    for radius_mm in (0.0, 6.0):
        result = organsim.replay(model, session, kind="springs", tip_radius=radius_mm * 1e-3)
        forces_csv = tmp_path / f"forces_{radius_mm:g}.csv"
        code, _, err = run_program("replay", path, session, "--model", "springs", "--tip-radius", radius_mm, "--fast",
                                   "--forces", forces_csv, "--quiet")
        assert code == 0, err
        table = np.loadtxt(forces_csv, delimiter=",", skiprows=1)
        np.testing.assert_allclose(result["forces"][0], table[:, 2:5], rtol=1e-8, atol=1e-12)
        peaks[radius_mm] = np.linalg.norm(result["forces"][0], axis=1).max()
    assert peaks[0.0] > 0
    assert abs(np.log(peaks[6.0] / peaks[0.0])) > 0.05
    with pytest.raises(ValueError, match="tip_radius"):
        organsim.replay(model, session, tip_radius=-1.0)


def test_errors_carry_the_programs_one_line_messages(tmp_path):
    missing = tmp_path / "missing.organ"
    with pytest.raises(organsim.Error) as error:
        organsim.load(missing)
    code, _, err = run_program("info", missing)
    assert code == 1 and str(error.value) in err
    assert "\n" not in str(error.value)

    truncated = tmp_path / "truncated.organ"
    truncated.write_bytes(b"ORGN\x01")
    with pytest.raises(organsim.Error):
        organsim.load(truncated)

    with pytest.raises(organsim.Error, match="outside"):
        organsim.bake(SAMPLES / "phantom_ct.nii.gz", tmp_path / "x.organ", seed=(5000, 0, 0))
    with pytest.raises(ValueError, match="tet-size"):
        organsim.bake(SAMPLES / "phantom_ct.nii.gz", tmp_path / "x.organ", tet_size="big")
    with pytest.raises(ValueError):
        organsim.bake(SAMPLES / "phantom_ct.nii.gz", tmp_path / "x.organ", no_such_option=1)
    assert not (tmp_path / "x.organ").exists()


def test_the_readme_example_runs(tmp_path, monkeypatch):
    readme = (REPOSITORY / "README.md").read_text()
    example = re.search(r"<!-- python example -->\s*```python\n(.*?)```", readme, re.S).group(1)
    assert len(example.strip().splitlines()) <= 12
    monkeypatch.chdir(tmp_path)
    (tmp_path / "data_samples").symlink_to(SAMPLES)
    exec(compile(example, "README.md", "exec"), {})
    assert (tmp_path / "phantom.organ").exists()


def test_the_force_depth_example_draws_its_plot(tmp_path, monkeypatch):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "data_samples").symlink_to(SAMPLES)
    script = REPOSITORY / "docs" / "examples" / "force_depth.py"
    exec(compile(script.read_text(), str(script), "exec"), {"__name__": "__main__"})
    png = tmp_path / "force_depth.png"
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bake_options_are_the_pipelines_own_and_bake_the_same_model(tmp_path):
    # The keywords set BakeOptions' fields (no command line is built); baking
    # those options directly writes the program's model, byte for byte.
    options = organsim.bake_options(SAMPLES / "phantom_ct.nii.gz", tmp_path / "direct.organ", **QUICK_BAKE,
                                    no_beam_tables=True, closing=2.0)
    assert options.surface.target_vertices == 800 and options.tetrahedra.tet_size_mm == 12.0
    assert options.beams.stations == 8 and options.beam_tables is False
    assert options.label_closing_radius_mm == options.seeded.closing_radius_mm == 2.0
    report = organsim.bake_with(options)
    assert report["beams"]["stations"] == 0
    code, _, err = run_program("bake", SAMPLES / "phantom_ct.nii.gz", "-o", tmp_path / "program.organ", "--seed",
                               "-65,5,0", "--surface-vertices", "800", "--tet-size", "12", "--stations", "8",
                               "--section-samples", "32", "--no-beam-tables", "--closing", "2")
    assert code == 0, err
    assert (tmp_path / "direct.organ").read_bytes() == (tmp_path / "program.organ").read_bytes()
    model = organsim.load(tmp_path / "direct.organ")
    with pytest.raises(organsim.Error, match="no-beam-tables"):
        organsim.Simulation(model, "beam")
    assert organsim.Simulation(model, "springs").kind == "springs"
