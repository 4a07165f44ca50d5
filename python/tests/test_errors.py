"""Bad input raises meshrad's exceptions with the CLI's message (file, line, key); the
interpreter survives every one."""

import numpy as np
import pytest

import meshrad


@pytest.fixture(scope="module")
def scene():
    return meshrad.Scene.embedded()


@pytest.fixture(scope="module")
def solution(scene):
    return meshrad.solve(scene, backend="cpu", rays=32, bounces=1)


def test_a_missing_file_is_a_file_error(tmp_path):
    missing = tmp_path / "none.toml"
    with pytest.raises(meshrad.FileError) as e:
        meshrad.load(missing)
    assert isinstance(e.value, OSError) and isinstance(e.value, ValueError)
    assert str(missing) in str(e.value) and e.value.path == str(missing)


def test_a_malformed_scene_names_file_and_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[[object]]\nmesh = \n")
    with pytest.raises(meshrad.Error) as e:
        meshrad.load(bad)
    assert str(bad) in str(e.value) and "line 2" in str(e.value)


def test_a_bad_mesh_names_its_line(tmp_path):
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    (tmp_path / "s.toml").write_text('[[object]]\nmesh = "m.obj"\n[[light]]\ntype = "point"\n'
                                     "position = [0.2, 0.2, 1.0]\nintensity = [1.0, 1.0, 1.0]\n")
    with pytest.raises(meshrad.Error) as e:
        meshrad.load(tmp_path / "s.toml")
    assert e.value.path.endswith("m.obj") and e.value.line == 4, str(e.value)


def test_solver_keys_are_checked_by_name(scene):
    with pytest.raises(meshrad.Error, match="parameter `rays`") as e:
        meshrad.solve(scene, backend="cpu", rays=-1)
    assert e.value.key == "rays"
    with pytest.raises(meshrad.Error, match="unknown field `raze`"):
        meshrad.solve(scene, backend="cpu", raze=3)
    with pytest.raises(meshrad.Error, match="bounces"):
        meshrad.solve(scene, backend="cpu", bounces="three")
    with pytest.raises(meshrad.Error, match="None is not a value"):
        meshrad.solve(scene, backend="cpu", seed=None)
    with pytest.raises(meshrad.Error, match="backend `fast`"):
        meshrad.solve(scene, backend="fast")
    with pytest.raises(meshrad.Error, match="device is chosen for the GPU backend"):
        meshrad.solve(scene, backend="cpu", device="0")


def test_memory_beyond_the_bound_is_a_resource_error(scene):
    with pytest.raises(meshrad.ResourceError) as e:
        meshrad.solve(scene, backend="cpu", max_memory="1M")
    assert isinstance(e.value, MemoryError) and "1M" in str(e.value) or "1.0 MiB" in str(e.value)
    with pytest.raises(meshrad.Error, match="max_memory"):
        meshrad.solve(scene, backend="cpu", max_memory="lots")


def test_edits_are_checked_as_frames(root):
    scene = meshrad.load(root / "scenes/cornell_parts.toml")
    with pytest.raises(meshrad.Error, match="no such light") as e:
        scene.edit(lights={"sun": {"intensity": [1.0, 1.0, 1.0]}})
    assert e.value.key == "lights.sun"
    with pytest.raises(meshrad.Error, match="objects.tallbox.scale"):
        scene.edit(objects={"tallbox": {"scale": 1e30}})
    with pytest.raises(meshrad.Error, match="translate"):
        scene.edit(objects={"tallbox": {"translate": [1.0, float("nan"), 0.0]}})
    with pytest.raises(meshrad.Error, match="unknown key|spin"):
        scene.edit(objects={"tallbox": {"spin": 3}})
    # reach = "lights" cannot be edited: said at the edit.
    lights = meshrad.load(root / "scenes/cornell_box.toml", reach="lights")
    with pytest.raises(meshrad.Error, match="reach"):
        lights.edit(lights={"spot": {"intensity": [1.0, 1.0, 1.0]}})


def test_bad_points_name_the_row(solution):
    with pytest.raises(meshrad.Error, match=r"points\[1\]: values must be finite"):
        solution.probe([[0, 0, 0, 0, 1, 0], [0, np.nan, 0, 0, 1, 0]])
    with pytest.raises(meshrad.Error, match=r"points\[0\]: the normal has zero length"):
        solution.probe([[0, 0, 0, 0, 0, 0]])
    with pytest.raises(meshrad.Error, match="expected an \\(N, 6\\) array"):
        solution.probe(np.zeros((4, 5)))
    with pytest.raises(meshrad.Error, match="expected an \\(N, 6\\) array"):
        solution.probe(np.zeros((0, 6)))
    with pytest.raises(meshrad.Error, match="values must be finite"):
        solution.probe([[1e39, 0, 0, 0, 1, 0]])


def test_a_raising_progress_callback_is_raised_after_the_work(scene):
    def boom(stage, done, total):
        raise KeyError("from the callback")

    with pytest.raises(KeyError, match="from the callback"):
        meshrad.solve(scene, backend="cpu", rays=32, bounces=1, progress=boom)
    with pytest.raises(TypeError, match="progress"):
        meshrad.solve(scene, backend="cpu", progress=3)


def test_outputs_never_replace_inputs(solution, tmp_path, root):
    with pytest.raises(meshrad.Error):
        solution.write(tmp_path / "o", export_nodes=tmp_path / "o" / "total.exr")
    assert not (tmp_path / "o" / "total.exr").exists()
    with pytest.raises(meshrad.Error, match="exposure"):
        solution.write(tmp_path / "o", exposure="bright")
