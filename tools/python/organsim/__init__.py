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
import os

from ._organsim import Error, Model, MultiBeam, Simulation, __version__, beam_section_fields
from ._organsim import _bake, _load, _replay

__all__ = ["Error", "Model", "MultiBeam", "Simulation", "__version__", "bake", "beam_section_fields", "load",
           "replay"]


def load(path):
    """Reads a .organ model file (checked: a bad file raises organsim.Error).

    Its arrays (surface_vertices, surface_triangles, volume_vertices, tetrahedra,
    fixed_points, beam_sections) are read-only numpy views of the model, in m."""
    return _load(os.fspath(path))


def replay(model, session, kind="beam", merge="influence", fixed_radius=0.010):
    """`organsim replay --fast` of a session file through the real-time engine.

    Returns a dict: times (R,) s, forces (tools, R, 3) N as sent to each device,
    in_contact (tools, R), duration s. Bit-identical to the program's forces."""
    return _replay(model, os.fspath(session), kind, merge, fixed_radius)


def _argument(value):
    """One option value as the command line writes it: X,Y,Z for a point."""
    if isinstance(value, (list, tuple)):
        return ",".join(format(v, "g") if isinstance(v, float) else str(v) for v in value)
    if hasattr(value, "tolist"):  # a numpy array or scalar
        return _argument(value.tolist())
    return os.fspath(value) if isinstance(value, os.PathLike) else str(value)


def bake(ct, output, **options):
    """Bakes a CT into a model file, as `organsim bake CT -o OUTPUT [options]`.

    Every option of `organsim bake --help` is a keyword argument, dashes written as
    underscores: label="mask.nii.gz", seed=(x, y, z) in mm (or a list of such
    points for several seeds), fixed_point=(x, y, z), tet_size=4.0, stations=20,
    young_modulus=5000, ... A flag is True. Coordinates are in mm here, as on
    the command line and in 3D Slicer. Returns the report (`bake --json`) as a dict.
    """
    arguments = [os.fspath(ct), "-o", os.fspath(output)]
    for name, value in options.items():
        option = "--" + name.replace("_", "-")
        if value is None or value is False:
            continue
        if value is True:
            arguments.append(option)
        elif isinstance(value, (list, tuple)) and value and isinstance(value[0], (list, tuple)):
            for item in value:  # a repeatable option: seed=[(x, y, z), (x, y, z)]
                arguments += [option, _argument(item)]
        else:
            arguments += [option, _argument(value)]
    try:
        return json.loads(_bake(arguments))
    except ValueError as error:
        raise ValueError(str(error)) from None
