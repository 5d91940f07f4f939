"""The installable package: one version string, complete dependencies, and a
``solver`` that works from any folder.

- ``python -m solver --version`` / ``keys`` and the README's Python API snippet
  run from a temporary folder outside the checkout.
- A fresh virtual environment (the test environment's packages through a .pth
  file) gets the checkout with ``pip install --no-deps --no-build-isolation``
  (editable, and a plain install of a copy): ``mts-solver --version``, the
  installed metadata and the snippet then work with no PYTHONPATH.
- pyproject.toml takes its version from ``solver.__version__`` and declares every
  third-party module that solver/ imports, with requirements.txt's pins.
"""
from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tomllib
from pathlib import Path

import pytest

from conftest import ROOT

import solver

# import name -> distribution name, where they differ
DISTRIBUTION = {"yaml": "PyYAML"}


def readme_snippet() -> str:
    """The README's first ```python block (its Python API example)."""
    text = (ROOT / "README.md").read_text()
    m = re.search(r"```python\n(.*?)```", text, re.S)
    assert m, "README.md has no ```python block"
    return m[1]


def clean_env(**extra) -> dict:
    """This process's environment without PYTHONPATH: only what is installed counts."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(MPLBACKEND="Agg", **extra)
    return env


def run(cmd, cwd, env, timeout=300):
    return subprocess.run(list(map(str, cmd)), capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=timeout)


def check_snippet(python, cwd: Path, env):
    """Run the README snippet with ``python`` in ``cwd``: it prints the error of
    six_dof's probe against the exact solution and writes six_dof.h5 there."""
    script = cwd / "snippet.py"
    script.write_text(readme_snippet())
    proc = run([python, script], cwd, env)
    assert proc.returncode == 0, proc.stderr
    m = re.fullmatch(r"max error (\S+) m after (\S+) s of stepping\n", proc.stdout)
    assert m, proc.stdout
    assert 0 < float(m[1]) < 1e-5 and float(m[2]) > 0            # 2.9e-7 at ratio 10
    assert (cwd / "six_dof.h5").is_file()


def test_python_m_solver_and_the_readme_snippet_work_outside_the_checkout(tmp_path):
    env = clean_env(PYTHONPATH=str(ROOT))
    proc = run([sys.executable, "-m", "solver", "--version"], tmp_path, env)
    assert proc.returncode == 0 and proc.stdout == f"mts-solver {solver.__version__}\n", proc
    proc = run([sys.executable, "-m", "solver", "keys"], tmp_path, env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split()[0] == "name" and "\ntime.end " in proc.stdout
    check_snippet(sys.executable, tmp_path, env)


def fresh_venv(path: Path) -> Path:
    """A venv without pip of its own that sees this environment's packages (.pth)."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(path)], check=True,
                   timeout=120)
    python = path / "bin" / "python"
    site = run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
               path, clean_env()).stdout.strip()
    Path(site, "test_env.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    return python


def pip_install(python: Path, target, cwd: Path):
    proc = run([python, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                "--no-index", *target], cwd, clean_env())
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.parametrize("editable", [True, False])
def test_pip_install_gives_a_console_script_and_an_importable_package(editable, tmp_path):
    python = fresh_venv(tmp_path / "venv")
    if editable:
        pip_install(python, ["-e", ROOT], tmp_path)
    else:
        # a copy of what a wheel is built from (a plain install builds in the tree)
        src = tmp_path / "src"
        shutil.copytree(ROOT / "solver", src / "solver",
                        ignore=shutil.ignore_patterns("__pycache__"))
        for name in ("pyproject.toml", "README.md"):
            shutil.copy(ROOT / name, src / name)
        pip_install(python, [src], tmp_path)
        shutil.rmtree(src)                                     # the install stands alone
    outside = tmp_path / "outside"
    outside.mkdir()
    env = clean_env()
    proc = run([tmp_path / "venv" / "bin" / "mts-solver", "--version"], outside, env)
    assert proc.returncode == 0 and proc.stdout == f"mts-solver {solver.__version__}\n", proc
    proc = run([python, "-c", "import importlib.metadata as m, solver; "
                "print(m.version('mts-solver')); print(solver.__file__)"], outside, env)
    assert proc.returncode == 0, proc.stderr
    version, where = proc.stdout.split()
    assert version == solver.__version__
    inside = Path(where).resolve().is_relative_to(ROOT)
    assert inside == editable, where                           # editable: this checkout
    proc = run([tmp_path / "venv" / "bin" / "mts-solver", "schemes"], outside, env)
    assert proc.returncode == 0 and "coupling.scheme" in proc.stdout, proc.stderr
    check_snippet(python, outside, env)


def pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_the_version_has_one_source():
    project = pyproject()
    assert "version" not in project["project"] and project["project"]["dynamic"] == ["version"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "solver.__version__"}
    assert re.fullmatch(r"\d+\.\d+\.\d+", solver.__version__)


def third_party_imports() -> set[str]:
    """Top-level modules imported anywhere in solver/ that are not stdlib or solver."""
    found = set()
    for path in (ROOT / "solver").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                found.update(a.name.split(".")[0] for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module.split(".")[0])
    return {m for m in found if m not in sys.stdlib_module_names and m != "solver"}


def declared() -> dict[str, str]:
    """pyproject dependency name (lower case) -> its requirement string."""
    out = {}
    for req in pyproject()["project"]["dependencies"]:
        out[re.match(r"[A-Za-z0-9_.-]+", req)[0].lower()] = req
    return out


def pins() -> dict[str, str]:
    """name (lower case) -> 'name==version' from requirements*.txt."""
    out = {}
    for name in ("requirements.txt", "requirements-petsc.txt"):
        for line in (ROOT / name).read_text().splitlines():
            line = line.split("#")[0].strip()
            if "==" in line:
                out[line.split("==")[0].lower()] = line
    return out


def test_every_imported_third_party_module_is_a_declared_dependency_with_its_pin():
    imported = third_party_imports()
    assert {"numpy", "scipy", "numba", "petsc4py", "mpi4py", "yaml"} <= imported   # the scan works
    deps, pinned = declared(), pins()
    missing = sorted(m for m in imported if DISTRIBUTION.get(m, m).lower() not in deps)
    assert not missing, f"imported by solver/ but not in pyproject dependencies: {missing}"
    unused = sorted(set(deps) - {DISTRIBUTION.get(m, m).lower() for m in imported})
    assert not unused, f"pyproject dependencies solver/ never imports: {unused}"
    for name, req in deps.items():
        want = pinned[name]
        if name in ("petsc4py", "mpi4py"):        # built against the system's MPI: a lower bound
            want = want.replace("==", ">=")
        assert req == want, f"pyproject says {req}, requirements say {pinned[name]}"


# ------------------------------------------------------------------ docs a user navigates
LINK = re.compile(r"\]\(([^)\s]+)\)")


def doc_pages() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def test_every_relative_link_in_the_readme_and_docs_resolves():
    """Links to files (and to their headings' anchors) resolve from the page
    that has them; docs/dev/ pages are written by the developers of each part."""
    def anchors(page: Path) -> set[str]:
        out = set()
        for line in page.read_text().splitlines():
            if line.startswith("#"):
                title = line.lstrip("#").strip().lower()
                out.add(re.sub(r"[^\w\- ]", "", title).replace(" ", "-"))
        return out
    broken = []
    for page in doc_pages():
        for target in LINK.findall(page.read_text()):
            if re.match(r"[a-z]+:", target):                        # http:, mailto:
                continue
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            if dest.parent == ROOT / "docs" / "dev" and not dest.exists():
                continue                                             # merged from other branches
            if not dest.exists() or (anchor and dest.suffix == ".md" and
                                     anchor not in anchors(dest)):
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert not broken, broken


def test_the_readme_is_an_entry_page_that_links_every_docs_section():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 200
    for page in ("docs/index.md", "docs/guide/running.md", "docs/reference/cli.md",
                 "docs/theory/index.md", "docs/benchmarks/index.md", "docs/developer.md"):
        assert f"]({page}" in text, page
    assert "pip install -e ." in text and "./run.sh test" in text


def test_the_docs_index_links_every_docs_page():
    index = ROOT / "docs" / "index.md"
    linked = {(index.parent / t.partition("#")[0]).resolve()
              for t in LINK.findall(index.read_text()) if not re.match(r"[a-z]+:", t)}
    pages = [p for p in (ROOT / "docs").rglob("*.md") if p != index and "dev" not in
             p.relative_to(ROOT / "docs").parts]
    missing = sorted(str(p.relative_to(ROOT)) for p in pages if p.resolve() not in linked)
    assert not missing, f"docs/index.md does not link {missing}"


def test_the_first_continuum_scene_walk_through_runs_as_written(tmp_path):
    """docs/guide/first-continuum-scene.md's scene, from a copy whose mesh path
    points at meshes/: it completes with the errors the page prints, the
    too-large step is refused with the critical step the page gives, and the
    implicit partition takes that step."""
    page = (ROOT / "docs" / "guide" / "first-continuum-scene.md").read_text()
    scene, = re.findall(r"```yaml\n(.*?)```", page, re.S)
    assert "mesh: meshes/bar2d.geo" in scene
    (tmp_path / "my_bar.yaml").write_text(
        scene.replace("mesh: meshes/bar2d.geo", f"mesh: {ROOT / 'meshes' / 'bar2d.geo'}"))
    env = clean_env(PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "solver", "my_bar.yaml"]
    proc = run(cmd, tmp_path, env)
    assert proc.returncode == 0, proc.stderr
    for line in re.findall(r"^\[solver\]   probe mid: .*$", page, re.M):
        assert line in proc.stdout.splitlines(), line
    assert "total mass 6.63552e-05 kg" in proc.stdout and "critical step 1.462e-07 s" in proc.stdout
    assert (tmp_path / "results" / "my_bar.h5").is_file()
    proc = run(cmd + ["--set", "time.dt=2.0e-7"], tmp_path, env)
    assert proc.returncode == 2 and "is unstable, critical step 1.462e-07 s" in proc.stderr
    proc = run(cmd + ["--set", "time.dt=2.0e-7", "--set", "partitions.fem.integrator=implicit"],
               tmp_path, env)
    assert proc.returncode == 0 and "40 system steps to t = 8e-06 s" in proc.stdout, proc.stderr
    proc = run(cmd + ["--set", "model.fixed=[rigth]"], tmp_path, env)
    assert proc.returncode == 2
    assert proc.stderr.strip() in page, proc.stderr


# ------------------------------------------------------------------ the console's forms
def solver_cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "solver", *args], cwd=cwd, text=True,
                          capture_output=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})


@pytest.mark.parametrize("args, message", [
    (["keys", "--update"], "error: keys --update needs the markdown file whose tables it replaces"),
    (["keys", "--update", "missing.md"], "error: keys --update: missing.md: No such file or directory"),
    (["keys", "--update", "plain.md"], "error: keys --update: plain.md has no <!-- keys: --> or "
                                       "<!-- schemes: --> marker to put the tables between"),
])
def test_keys_update_refuses_a_missing_or_unmarked_file_in_one_line(tmp_path, args, message):
    (tmp_path / "plain.md").write_text("# no tables here\n")
    proc = solver_cli(*args, cwd=tmp_path)
    assert (proc.returncode, proc.stderr.strip(), proc.stdout) == (2, message, "")
    assert (tmp_path / "plain.md").read_text() == "# no tables here\n"


def test_sweep_and_plot_are_forms_of_the_console_and_h_anywhere_is_help(tmp_path):
    sweep = solver_cli("sweep", "--help", cwd=tmp_path)
    assert sweep.returncode == 0 and "--ratios" in sweep.stdout, sweep.stderr
    plot = solver_cli("plot", "nothing.h5", cwd=tmp_path)
    assert plot.returncode != 0 and "nothing.h5" in plot.stderr and "no scene file" not in plot.stderr
    usage = solver_cli("scene.yaml", "-h", cwd=tmp_path)
    assert usage.returncode == 0 and usage.stdout.startswith("usage: ") and not usage.stderr
