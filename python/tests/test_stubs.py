"""The module documents itself: type stubs that follow the bindings, and a docstring on
every public member."""
import inspect
import os
import pathlib
import re
import subprocess
import sys

import torch

import fskin
import fskin._fskin

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_the_shipped_stubs_match_the_bindings():
    result = subprocess.run([sys.executable, str(ROOT / "tools" / "generate_python_stubs.py"), "--check"],
                            capture_output=True, text=True, env=dict(os.environ))
    assert result.returncode == 0, result.stderr
    stubs = (ROOT / "python" / "fskin" / "_fskin.pyi").read_text()
    assert "at::" not in stubs and "torch.Tensor" in stubs
    assert (ROOT / "python" / "fskin" / "py.typed").exists()


def _documentation(name, member):
    """A member's own text: pybind11 puts its signature(s) first ('name(...) -> ...', or a
    property getter's '(arg0: ...) -> ...'), so those lines do not count."""
    if isinstance(member, property):
        texts = [inspect.getdoc(member), inspect.getdoc(member.fget) if member.fget else None]
    else:
        texts = [inspect.getdoc(member)]
    signature = re.compile(r"^(\d+\. )?(" + re.escape(name) + r")?\(.*\)( -> .*)?$")
    lines = []
    for text in texts:
        lines += [line for line in (text or "").splitlines()
                  if line.strip() and not signature.match(line) and line != "Overloaded function."]
    return lines


def test_every_public_member_has_a_docstring():
    missing = []
    for name in fskin.__dict__:
        if name.startswith("_"):
            continue
        value = getattr(fskin, name)
        if inspect.ismodule(value) or name in ("Error",):
            continue
        if not callable(value):
            continue
        if not _documentation(name, value):
            missing.append(name)
        if inspect.isclass(value):
            for member, attribute in vars(value).items():
                if member.startswith("_") and member not in ("__init__", "__len__", "__getitem__"):
                    continue
                if isinstance(value, type) and issubclass(value, torch.nn.Module) and member in (
                        "training", "T_destination", "dump_patches"):
                    continue
                if not _documentation(member, attribute):
                    missing.append(f"{name}.{member}")
    assert not missing, f"public members without a docstring: {missing}"


def test_a_typed_user_script_passes_mypy_against_the_stubs(tmp_path):
    """mypy (Debian's, installed by scripts/setup.sh) reads python/fskin's stubs and
    modules; an error in the stubs or a signature that does not say its types fails."""
    script = ROOT / "python" / "tests" / "typed_user_script.py"
    result = subprocess.run(["mypy", "--cache-dir", str(tmp_path / "cache"), "--no-error-summary", str(script)],
                            capture_output=True, text=True,
                            env=dict(os.environ, MYPYPATH=str(ROOT / "python")))
    assert result.returncode == 0, result.stdout + result.stderr
    # The checker sees the types: a wrong one is an error.
    wrong = tmp_path / "wrong.py"
    wrong.write_text("import fskin\nfskin.VoxelBox.fit(None, 'thirty-two')\n")
    result = subprocess.run(["mypy", "--cache-dir", str(tmp_path / "cache"), str(wrong)], capture_output=True,
                            text=True, env=dict(os.environ, MYPYPATH=str(ROOT / "python")))
    assert result.returncode == 1 and "VoxelBox" in result.stdout, result.stdout
