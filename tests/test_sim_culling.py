"""Cheaper eye images that are the same images: an eye reading only the part of its sensor that
sees a region (hila_lang.robot.lens.sensor_window) and the mesh extents that let the renderer
leave out links out of view (hila_lang.sim.culling).  The images themselves, culled and windowed
against whole, are compared in tests/test_robot_backend.py (it has the robot loaded)."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.robot.lens import sensor_window
from hila_lang.sim.camera import look_at
from hila_lang.sim.culling import mesh_bounds


def test_sensor_window_is_the_regions_projection_grown_and_clipped():
    from hila_lang.robot.lens import eye_calibration

    calib = eye_calibration("left")
    camera = look_at((0.0, 0.0, 0.5), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0))
    square = np.array([[-0.02, -0.02, 0.0], [0.02, -0.02, 0.0], [0.02, 0.02, 0.0], [-0.02, 0.02, 0.0]])
    u0, v0, u1, v1 = sensor_window(square, calib, camera, margin=3)
    cx, cy = calib.K[0, 2], calib.K[1, 2]
    assert u0 < cx < u1 and v0 < cy < v1  # the middle of the view
    assert 20 < u1 - u0 < 60 and 20 < v1 - v0 < 60  # 4 cm at 0.5 m: about 20 px each way, plus margins
    wide = sensor_window(square * 40, calib, camera)
    assert wide is None or wide == (0, 0, 320, 240)
    behind = square + np.array([0.0, 0.0, 1.0])
    assert sensor_window(behind, calib, camera) is None
    with pytest.raises(InputError, match=r"region must be finite world points of shape \(N, 3\)"):
        sensor_window(np.array([1.0, 2.0]), calib, camera)
    with pytest.raises(InputError, match="region"):
        sensor_window(np.full((2, 3), np.nan), calib, camera)


def test_mesh_bounds_read_binary_and_text_meshes(tmp_path):
    rng = np.random.default_rng(0)
    tri = rng.uniform(-2, 3, (5, 3, 3)).astype(np.float32)
    rows = np.zeros(5, dtype=np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")]))
    rows["v"] = tri
    binary = tmp_path / "part.stl"
    binary.write_bytes(b"\0" * 80 + np.uint32(5).tobytes() + rows.tobytes())
    lo, hi = mesh_bounds(str(binary))
    assert np.allclose(lo, tri.reshape(-1, 3).min(axis=0)) and np.allclose(hi, tri.reshape(-1, 3).max(axis=0))
    text = tmp_path / "part_text.stl"
    text.write_text("solid x\n" + "".join(f"  vertex {a} {b} {c}\n" for a, b, c in tri.reshape(-1, 3)) + "endsolid x\n")
    assert np.allclose(mesh_bounds(str(text))[1], hi)
    obj = tmp_path / "part.obj"
    obj.write_text("# a mesh\nv 1 2 3\nv -1 5 0\nvn 0 0 1\nf 1 2 1\n")
    assert mesh_bounds(str(obj)) == ((-1.0, 2.0, 0.0), (1.0, 5.0, 3.0))
    (tmp_path / "part.dae").write_text("<COLLADA/>")
    assert mesh_bounds(str(tmp_path / "part.dae")) is None  # unknown extent: never left out
    assert mesh_bounds(str(tmp_path / "missing.stl")) is None
