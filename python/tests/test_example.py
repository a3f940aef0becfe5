"""The example script runs end to end (quick sizes) and writes what it says."""
import json
import os
import subprocess
import sys

import pytest

import fskin

EXAMPLE = os.path.join(os.path.dirname(__file__), "..", "examples", "train_and_repose.py")


@pytest.mark.skipif(not fskin.built_with_embree(), reason="building a dataset needs Embree")
def test_train_and_repose_example(tmp_path):
    out = tmp_path / "example"
    done = subprocess.run([sys.executable, EXAMPLE, str(out), "--quick", "--steps", "30"], capture_output=True,
                          text=True, env=dict(os.environ))
    assert done.returncode == 0, done.stdout + done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] == 30 and summary["method"] == "fast-snarf"
    assert 0.0 <= summary["test_ood_iou_surf"] <= 1.0
    assert summary["reposed_frames"] == 2
    canonical_vertices, canonical_faces = fskin.read_mesh(str(out / "canonical.ply"))
    assert canonical_vertices.shape[0] == summary["canonical_vertices"] > 0
    for n in range(2):
        vertices, faces = fskin.read_mesh(str(out / f"unseen_{n}.ply"))
        assert vertices.shape == canonical_vertices.shape and (faces == canonical_faces).all()
        assert (vertices - canonical_vertices).abs().max() > 0  # it moved
    assert (out / "avatar.glb").read_bytes()[:4] == b"glTF"
    assert (out / "run" / "eval-test-ood.json").exists()


def test_the_readmes_first_snippet_runs_as_written():
    readme = open(os.path.join(os.path.dirname(__file__), "..", "..", "README.md")).read()
    snippet = readme.split("```python\n", 1)[1].split("```", 1)[0]
    scope = {}
    exec(compile(snippet, "README.md (first Python snippet)", "exec"), scope)
    x_canonical, valid = scope["x_canonical"], scope["valid"]
    assert x_canonical.shape[:2] == scope["vertices"].shape[:2] and valid.any(-1).float().mean() > 0.9


def test_pip_installs_the_module_offline(tmp_path):
    # The build directory of the module under test: PYTHONPATH=<build>/python.
    build_dir = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(fskin.__file__))))
    source = os.path.join(os.path.dirname(__file__), "..")
    target = tmp_path / "site"
    environment = dict(os.environ, FSKIN_BUILD_DIR=build_dir, PIP_NO_INDEX="1")
    done = subprocess.run([sys.executable, "-m", "pip", "install", "--no-build-isolation", "--no-deps", "--target",
                           str(target), source], capture_output=True, text=True, env=environment)
    assert done.returncode == 0, done.stdout + done.stderr
    assert (target / "fskin" / "py.typed").exists()
    probe = "import fskin, torch; print(fskin.__file__); print(fskin.humanoid(resolution=32).num_joints)"
    environment["PYTHONPATH"] = str(target)
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=environment, check=True)
    location, joints = out.stdout.split()[-2:]
    assert location.startswith(str(target)) and int(joints) == 24
