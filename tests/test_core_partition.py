"""The parts a Partition is composed of, each alone with real numbers, the
public interface the coupling schemes use, and that no module outside
solver/partitions reads another object's private attributes."""
import ast
import math
from pathlib import Path

import numpy as np
import pytest

from conftest import built, raw_scene

ROOT = Path(__file__).resolve().parents[1]


def petsc():
    from solver.petscutil import init
    return init([])


# --- State ------------------------------------------------------------------

def test_state_vecs_share_memory_with_the_arrays():
    from solver.partitions.state import State
    P = petsc()
    st = State(4, P.COMM_SELF, ("ut", "vt"))
    assert st.state.shape == (3, 4) and st.R.shape == (4,)
    st.u.set(2.0)
    st.state[1, 3] = 7.0
    st.A[0] = -1.5
    st.vecs["vt"].setValue(2, 4.25)
    st.vecs["vt"].assemble()
    st.R[1] = 3.0
    assert st.U.tolist() == [2.0, 2.0, 2.0, 2.0]
    assert st.v.getArray()[3] == 7.0 and st.V[3] == 7.0
    assert st.a.getArray()[0] == -1.5
    assert st.work["vt"][2] == 4.25 and st.work["ut"].tolist() == [0.0] * 4
    assert st.r.getArray()[1] == 3.0
    assert len(st.all_vecs()) == 6
    st.destroy()


# --- Loads ------------------------------------------------------------------

def ramp_loads():
    """Two groups: g = 3t on DOFs 0 (owned, scale 1) and 2 (external, scale 2);
    g = 5 on DOF 1 (owned, scale 0.5: the scalar path)."""
    from solver.partitions.loads import LoadGroup, Loads
    return Loads([LoadGroup(0, lambda t: 3.0 * t, [0, 2], [1.0, 2.0], [True, False]),
                  LoadGroup(2, lambda t: 5.0, [1], [0.5], [True])])


def test_loads_work_of_a_known_path_is_its_trapezoidal_value():
    loads = ramp_loads()
    U, R = np.zeros(3), np.zeros(3)
    loads.apply(R, 0.0)
    loads.remember(U)
    h = 0.25
    for k in range(1, 5):
        t = k * h
        U[:] = [t * t, 2.0 * t, 100.0 * t]          # the external DOF's motion is not ours
        R[:] = 0.0
        loads.apply(R, t)
        loads.track(U)
    # g = 3t on u = t^2: 1.5 h sum (t_k-1 + t_k)^2 = 1.96875 (the integral is 2);
    # g = 5 x 0.5 on u = 2t: 2.5 x 2 = 5 exactly
    assert loads.work == pytest.approx(1.96875 + 5.0, rel=1e-14)
    assert R.tolist() == [3.0, 2.5, 6.0]
    assert [g.key for g in loads.owned] == [0, 2]
    assert loads.memory() == {0: 3.0, 2: 5.0}


def test_loads_off_applies_nothing_and_memory_restores():
    loads = ramp_loads()
    R = np.zeros(3)
    with loads.off():
        loads.apply(R, 1.0)
    assert R.tolist() == [0.0, 0.0, 0.0]
    loads.apply(R, 1.0)
    assert R.tolist() == [3.0, 2.5, 6.0]
    loads.remember(np.zeros(3))                     # the memory is g at the last step
    assert loads.memory() == {0: 3.0, 2: 5.0}
    other = ramp_loads()
    U = np.array([0.5, 0.25, 9.0])
    other.restore(loads.memory(), U)
    assert other.groups[0].val_prev == 3.0 and other.groups[0].u_prev.tolist() == [0.5]
    assert other.groups[1].u_prev.tolist() == [0.25]


# --- Damping and the energy audit ---------------------------------------------

def spring_chain(P, k=(2.0, 3.0, 4.0)):
    """-K of a grounded chain ground-0-1-2 with springs k (a PETSc Mat) and K."""
    K = np.array([[k[0] + k[1], -k[1], 0.0], [-k[1], k[1] + k[2], -k[2]], [0.0, -k[2], k[2]]])
    M = P.Mat().createDense((3, 3), array=-K, comm=P.COMM_SELF)
    M.assemble()
    return M, K


def test_damping_is_absent_when_undamped():
    from types import SimpleNamespace

    from solver.partitions.damping import Damping
    from solver.scene.sections import Damping as Spec
    P = petsc()
    mass = np.ones(3)
    assert Damping.of(None, mass, P.COMM_SELF) is None
    assert Damping.of(Spec(), mass, P.COMM_SELF) is None
    d = Damping.of(SimpleNamespace(alpha=0.5, beta=0.0, active=True), mass, P.COMM_SELF)
    assert d is not None and d.am.tolist() == [0.5, 0.5, 0.5]
    d.destroy()


@pytest.mark.parametrize("linear", [True, False])
def test_damping_residual_is_minus_alpha_m_v_minus_beta_k_v(linear):
    from solver.partitions.audit import EnergyAudit
    from solver.partitions.damping import Damping
    from solver.scene.sections import Damping as Spec
    P = petsc()
    Kneg, K = spring_chain(P)
    mass = np.array([1.0, 2.0, 4.0])
    alpha, beta, h = 0.3, 0.05, 0.01
    d = Damping.of(Spec(alpha=alpha, beta=beta), mass, P.COMM_SELF)
    u_arr, v_arr, r_arr = np.array([0.1, -0.2, 0.3]), np.array([1.0, 2.0, -1.0]), np.zeros(3)
    u, v, r = (P.Vec().createWithArray(x, comm=P.COMM_SELF) for x in (u_arr, v_arr, r_arr))
    audit = EnergyAudit(True, h, 3)
    audit.stepping = True
    if linear:
        d.linear(Kneg.mult, u, v, r, audit)
        expected = -K @ u_arr - alpha * mass * v_arr - beta * K @ v_arr
    else:
        Kneg.mult(u, r)                              # the partition's internal force
        d.nonlinear(Kneg, v, r, audit)
        expected = -K @ u_arr - alpha * mass * v_arr - beta * K @ v_arr
    assert np.allclose(r_arr, expected, rtol=1e-14, atol=0)
    # h v.C v with C = alpha M + beta K: 0.01 (0.3 x 13 + 0.05 x 41) = 0.0595
    assert audit.dissipated == pytest.approx(h * (alpha * v_arr @ (mass * v_arr)
                                                  + beta * v_arr @ K @ v_arr), rel=1e-14)
    assert audit.dissipated == pytest.approx(0.0595, rel=1e-14)
    d.clear_rows(1)
    assert d.am.tolist() == [0.3, 0.0, 0.0]
    for obj in (u, v, r, Kneg):
        obj.destroy()
    d.destroy()


def test_the_audit_counts_only_while_stepping_and_tracking():
    from solver.partitions.audit import EnergyAudit
    audit = EnergyAudit(True, 0.5, 2)
    audit.add(4.0)
    assert audit.dissipated == 0.0
    audit.stepping = True
    audit.add(4.0)
    assert audit.dissipated == 2.0
    idle = EnergyAudit(False, 0.5, 2)
    idle.stepping = True
    idle.add(4.0)
    assert idle.dissipated == 0.0


# --- integrators by type ------------------------------------------------------

@pytest.mark.parametrize("name,implicit,factor", [("explicit", False, 1.0 + 0.5 * 0.1 * 2.0),
                                                 ("implicit", True, 1.0), ("verlet", False, 1.0)])
def test_integrators_are_chosen_by_class(name, implicit, factor):
    from types import SimpleNamespace

    from solver.partitions import integrators
    spec = SimpleNamespace(integrator=name, beta=0.25, gamma=0.5)
    integ = integrators.make(spec)
    assert type(integ) is integrators.kind(spec) and integ.name == name
    assert integ.implicit is implicit and integ.needs_ksp is implicit
    assert integ.mass_damping_factor(0.1, 2.0) == pytest.approx(factor, rel=1e-15)
    with pytest.raises(ValueError):
        integrators.kind(SimpleNamespace(integrator="leapfrog"))


# --- a partition built from a small scene ---------------------------------------

def test_a_built_partition_exposes_the_public_interface(tmp_path):
    asm = built(raw_scene("six_dof"), tmp_path)
    fem, dem = asm.parts
    try:
        assert fem.built[0].startswith("stiffness matrix 4x4") and fem.built[1] == "lumped mass"
        assert dem.built[0].startswith("particles 4 (3 owned)")
        assert [g.key for g in fem.load_groups] == [0] and dem.load_groups == []
        assert np.array_equal(fem.inverse_mass, 1.0 / fem.mass)
        assert fem.ut is fem.vectors.vecs["ut"] and not hasattr(dem, "ut")
        assert fem.state is fem.vectors.state and fem.U.base is fem.state
        # internal_force: -K u of the unit chain ground-0-1-2-3 at u = e_0
        i0, i1 = fem.local_index(0, 0), fem.local_index(1, 0)
        fem.state[...] = 0.0
        fem.U[i0] = 1.0
        fem.internal_force(fem.u, fem.r)
        expected = np.zeros(4)
        expected[[i0, i1]] = -2.0, 1.0
        assert fem.R.tolist() == expected.tolist()
        fem.U[i0] = 0.0
        with fem.loads_off():
            fem.residual(1.0, fem.u, fem.v)
        assert not fem.R.any()
        fem.residual(1.0, fem.u, fem.v)                    # sin(pi/2 t) at node 1
        assert fem.R[i1] == pytest.approx(1.0, rel=1e-15) and np.count_nonzero(fem.R) == 1
        # one explicit Newmark step from rest (a_0 = 0): a = f(h)/m, u = beta h^2 a, v = gamma h a
        fem.A[:] = 0.0
        h = fem.dt
        fem.step_once(h)
        a = math.sin(0.5 * math.pi * h)
        assert fem.A[i1] == pytest.approx(a, rel=1e-14)
        assert fem.U[i1] == pytest.approx(0.25 * h * h * a, rel=1e-14)
        assert fem.V[i1] == pytest.approx(0.5 * h * a, rel=1e-14)
        fem.work = 1.25
        fem.dissipated = 0.5
        assert fem.loads.work == 1.25 and fem.audit.dissipated == 0.5
        assert fem.energies()[2:] == (1.25, 0.5)
    finally:
        asm.destroy()


def test_clear_external_mass_damping_leaves_the_owned_rows(tmp_path):
    raw = raw_scene("six_dof")
    raw["damping"], raw["loads"] = {"alpha": 0.2}, []
    asm = built(raw, tmp_path)
    fem, dem = asm.parts
    try:
        n = fem.n_own
        assert fem.damping.am.tolist() == pytest.approx((0.2 * fem.mass).tolist())
        fem.clear_external_mass_damping()
        assert fem.damping.am[:n].tolist() == pytest.approx((0.2 * fem.mass[:n]).tolist())
        assert not fem.damping.am[n:].any() and fem.damping.am.size > n
        # explicit Newmark folds gamma h alpha M into the diagonal solve, Verlet does not
        assert fem.inverse_mass[0] == pytest.approx(1.0 / (1.0 + 0.5 * fem.dt * 0.2), rel=1e-15)
        assert dem.inverse_mass[0] == 1.0
    finally:
        asm.destroy()


def test_an_undamped_partition_has_no_damping_terms(tmp_path):
    asm = built(raw_scene("six_dof"), tmp_path)
    try:
        assert all(p.damping is None for p in asm.parts)
        assert not asm.parts[0].track_dissipation          # linear and undamped
    finally:
        asm.destroy()


# --- privacy --------------------------------------------------------------------

def private_reads(source: str, name: str) -> list[str]:
    """``obj._x`` reads in module text ``source`` where obj is not self, cls or super()."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if not (isinstance(node, ast.Attribute) and node.attr.startswith("_")
                and not node.attr.startswith("__")):
            continue
        v = node.value
        if isinstance(v, ast.Name) and v.id in ("self", "cls"):
            continue
        if isinstance(v, ast.Call) and isinstance(v.func, ast.Name) and v.func.id == "super":
            continue
        out.append(f"{name}:{node.lineno}: {ast.unparse(node)}")
    return out


def test_no_module_outside_partitions_reads_a_private_attribute():
    files = [p for p in sorted((ROOT / "solver").rglob("*.py"))
             if "partitions" not in p.relative_to(ROOT / "solver").parts[:1]]
    assert len(files) > 20
    found = [hit for p in files for hit in private_reads(p.read_text(), p.relative_to(ROOT))]
    assert found == []


def test_the_scan_finds_a_private_read():
    source = "def f(F, self):\n    return F._step, self._ok, super()._x, F.__class__\n"
    assert private_reads(source, "m.py") == ["m.py:2: F._step"]


def test_force_objects_are_asked_through_their_declared_interface():
    """Both forces subclass Force (its defaults: nothing breaks, no dashpots, no
    temperature), and no module asks a force object with getattr/hasattr."""
    from solver.partitions.bonds import BondForce
    from solver.partitions.force import Force, LinearForce
    assert issubclass(LinearForce, Force) and issubclass(BondForce, Force)
    assert (LinearForce.bonded, LinearForce.break_strain, LinearForce.broken) == (False, None, ())
    assert BondForce.bonded and not BondForce.linear
    found = []
    for p in sorted((ROOT / "solver").rglob("*.py")):
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                    and node.func.id in ("getattr", "hasattr") and node.args \
                    and "force" in ast.unparse(node.args[0]).split("."):
                found.append(f"{p.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    assert found == [], "\n".join(found)
