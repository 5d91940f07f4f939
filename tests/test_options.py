"""PETSc options reach PETSc with each partition's prefix; -log_view has the stages."""
import pytest

from conftest import raw_scene, run_cli, write_scene


def _short(tmp_path):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 1.0
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    return write_scene(tmp_path / "s.yaml", raw)


@pytest.mark.parametrize("n", [None, 2])
def test_log_view_has_one_stage_per_partition_and_the_exchange(tmp_path, n):
    """On 1 and 2 ranks, also when ranks hold different partitions (3 ranks, a
    split partition, list the same stages, but -log_view's summary reductions
    take minutes when 3 ranks oversubscribe 2 cores)."""
    proc = run_cli([_short(tmp_path), "-log_view"], n=n)
    assert proc.returncode == 0, proc.stderr
    table = proc.stdout.split("Summary of Stages")[1].split("\n\n")[0]
    names = [line.split(":")[1].strip() for line in table.splitlines()[2:] if ":" in line]
    assert names == ["Main Stage", "fem", "dem", "exchange"], table
    shares = [float(line.split("%")[0].split()[-1]) for line in table.splitlines()[2:] if ":" in line]
    assert shares[2] > 0                       # the dem stage did the dem work


def test_prefixed_options_from_an_options_file(tmp_path):
    opts = tmp_path / "x.opts"
    opts.write_text("-fem_mat_type baij\n-dem_mat_type sell\n")
    proc = run_cli([_short(tmp_path), "-options_file", opts])
    assert proc.returncode == 0, proc.stderr
    assert "type seqbaij" in proc.stdout and "type seqsell" in proc.stdout
    assert "warning" not in proc.stderr


def test_unused_options_are_refused_before_stepping(tmp_path):
    """A misspelled option or a prefix that names no partition: refused once
    set-up has built every object and before anything is written, with the
    nearest known option."""
    proc = run_cli([_short(tmp_path), "-fem_mat_tpye", "baij", "-solid_mat_type", "aij"])
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert "-fem_mat_tpye (did you mean -fem_mat_type?)" in line
    assert "-solid_mat_type (no partition is named 'solid')" in line
    assert not (tmp_path / "o.h5").exists()


def test_every_matrix_type_gives_the_same_answer(tmp_path):
    """The values reach every type (COO assembly): the error against the exact
    solution is the default's to round-off, not merely the type string."""
    import h5py
    import numpy as np
    scene = _short(tmp_path)
    base = None
    for opts in ([], ["-dem_mat_type", "sell"], ["-fem_mat_type", "sell"],
                 ["-fem_mat_type", "dense"], ["-fem_mat_type", "baij"],
                 ["-fem_mat_type", "sbaij", "-dem_mat_type", "sbaij"]):
        proc = run_cli([scene, *opts])
        assert proc.returncode == 0, proc.stderr
        if opts:
            assert f"type seq{opts[1]}" in proc.stdout, proc.stdout
        with h5py.File(tmp_path / "o.h5") as f:
            u = f["probes/x3/displacement"][()]
            err = f["probes/x3"].attrs["max_rel_error"]
        if base is None:
            base, base_err = u, err
            assert 0 < err < 1e-6
        assert np.abs(u - base).max() <= 1e-13 * np.abs(base).max(), opts
        assert abs(err - base_err) <= 1e-6 * base_err, opts


def test_unused_options_consider_every_rank(tmp_path):
    """On 2 ranks -dem_mat_type is read only on the dem rank: it is used, not
    refused; a misspelled option is refused once; PETSc's own rank-0 list is
    not printed."""
    proc = run_cli([_short(tmp_path), "-dem_mat_type", "aij", "-fem_mat_typo", "aij"], n=2,
                   timeout=120)
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert "-fem_mat_typo (did you mean -fem_mat_type?)" in line
    assert "Option left" not in proc.stderr and "-dem_mat_type" not in proc.stderr
    proc = run_cli([_short(tmp_path), "-dem_mat_type", "aij"], n=2, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_solver_options_give_the_answer_or_are_refused(tmp_path):
    """An iterative solve chosen by option gives the direct solve's answer (the
    default rtol is 1e-12); a preconditioner alone under KSP preonly, which
    would apply it once and call that a solution, is refused in one line."""
    import h5py
    import numpy as np
    from conftest import raw_scene, write_scene
    raw = raw_scene("metamaterial_implicit")
    raw["reference"] = "none"
    scene = write_scene(tmp_path / "mi.yaml", raw)
    answers = {}
    for label, opts in [("lu", []), ("cg", ["-fem_ksp_type", "cg", "-fem_pc_type", "jacobi"]),
                        ("gmres", ["-fem_ksp_type", "gmres", "-fem_pc_type", "ilu"])]:
        out = tmp_path / f"{label}.h5"
        proc = run_cli([scene, "--set", f"output.file={out}", *opts])
        assert proc.returncode == 0, proc.stderr
        with h5py.File(out) as f:
            answers[label] = f["probes/p550/displacement"][()]
    scale = np.abs(answers["lu"]).max()
    assert scale > 0
    for label in ("cg", "gmres"):
        assert np.abs(answers[label] - answers["lu"]).max() <= 1e-9 * scale, label
    proc = run_cli([scene, "--set", f"output.file={tmp_path / 'j.h5'}", "-fem_pc_type", "jacobi"])
    assert proc.returncode == 2
    line, = proc.stderr.strip().splitlines()
    assert line.startswith("error: ") and "-fem_pc_type jacobi" in line and "preonly" in line
    assert not (tmp_path / "j.h5").exists()
