"""PETSc options reach PETSc with each partition's prefix; -log_view has the stages."""
from conftest import raw_scene, run_cli, write_scene


def _short(tmp_path):
    raw = raw_scene("six_dof")
    raw["time"]["end"] = 1.0
    raw["output"] = {"file": str(tmp_path / "o.h5")}
    return write_scene(tmp_path / "s.yaml", raw)


def test_log_view_has_one_stage_per_partition_and_the_exchange(tmp_path):
    proc = run_cli([_short(tmp_path), "-log_view"])
    assert proc.returncode == 0, proc.stderr
    table = proc.stdout.split("Summary of Stages")[1].split("\n\n")[0]
    names = [line.split(":")[1].strip() for line in table.splitlines()[2:] if ":" in line]
    assert names == ["Main Stage", "fem", "dem", "exchange"], table


def test_prefixed_options_from_an_options_file(tmp_path):
    opts = tmp_path / "x.opts"
    opts.write_text("-fem_mat_type baij\n-dem_mat_type sell\n")
    proc = run_cli([_short(tmp_path), "-options_file", opts])
    assert proc.returncode == 0, proc.stderr
    assert "type seqbaij" in proc.stdout and "type seqsell" in proc.stdout
    assert "warning" not in proc.stderr


def test_unused_options_are_reported(tmp_path):
    proc = run_cli([_short(tmp_path), "-fem_mat_tpye", "baij", "-solid_mat_type", "aij"])
    assert proc.returncode == 0, proc.stderr
    warned = [line for line in proc.stderr.splitlines() if line.startswith("warning")]
    assert len(warned) == 2
    assert "-fem_mat_tpye" in warned[0] and "-solid_mat_type" in warned[1]
