"""Element patch tests: rigid-body modes give zero force, uniform strain is
reproduced exactly, masses add up, inverted elements are refused."""
import numpy as np
import pytest

from solver.model.elements import FAMILIES, BadElement, Elastic, HEX_NODES, QUAD_NODES, lumped_mass, \
    stiffness, volumes

REFERENCE = {"tri3": np.array([[0, 0], [1, 0], [0, 1]], float), "quad4": (QUAD_NODES + 1) / 2,
             "tet4": np.vstack([np.zeros(3), np.eye(3)]), "hex8": (HEX_NODES + 1) / 2}
MATERIALS = {2: [Elastic(70e9, 0.33, 2700, "plane_stress", 3.2e-4), Elastic(70e9, 0.33, 2700, "plane_strain")],
             3: [Elastic(70e9, 0.33, 2700)]}


def distorted(name, n=5, seed=1):
    """n randomly distorted, positively oriented copies of the reference element."""
    rng = np.random.default_rng(seed)
    X0 = REFERENCE[name]
    d = X0.shape[1]
    A = np.eye(d) + 0.2 * rng.standard_normal((n, d, d))
    X = np.einsum("eij,aj->eai", A, X0) + rng.standard_normal((n, 1, d))
    X += 0.05 * rng.standard_normal(X.shape)             # non-affine distortion (quad, hex)
    return X


def rigid_modes(X):
    """Translations and infinitesimal rotations at coordinates X [e, a, d]: [m, e, a*d]."""
    e, a, d = X.shape
    modes = [np.broadcast_to(np.eye(d)[k], X.shape).reshape(e, a * d) for k in range(d)]
    pairs = [(0, 1)] if d == 2 else [(0, 1), (1, 2), (0, 2)]
    for i, j in pairs:
        u = np.zeros_like(X)
        u[..., i], u[..., j] = -X[..., j], X[..., i]
        modes.append(u.reshape(e, a * d))
    return modes


CASES = [(name, m) for name in FAMILIES for m in MATERIALS[FAMILIES[name].dim]]


@pytest.mark.parametrize("name,material", CASES, ids=[f"{n}-{m.kind}" for n, m in CASES])
def test_rigid_body_modes_give_zero_force(name, material):
    X = distorted(name)
    K = stiffness(FAMILIES[name], X, material)
    scale = np.abs(K).max()
    for u in rigid_modes(X):
        assert np.abs(np.einsum("eij,ej->ei", K, u)).max() < 1e-10 * scale
    assert np.allclose(K, np.transpose(K, (0, 2, 1)), rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("name,material", CASES, ids=[f"{n}-{m.kind}" for n, m in CASES])
def test_uniform_strain_energy_is_exact(name, material):
    X = distorted(name)
    fam = FAMILIES[name]
    d = fam.dim
    rng = np.random.default_rng(7)
    grad = rng.standard_normal((d, d)) * 1e-3
    eps = 0.5 * (grad + grad.T)
    u = np.einsum("ij,eaj->eai", grad, X).reshape(len(X), -1)
    K = stiffness(fam, X, material)
    energy = 0.5 * np.einsum("ei,eij,ej->e", u, K, u)
    voigt = (np.array([eps[0, 0], eps[1, 1], 2 * eps[0, 1]]) if d == 2 else
             np.array([eps[0, 0], eps[1, 1], eps[2, 2], 2 * eps[1, 2], 2 * eps[0, 2], 2 * eps[0, 1]]))
    exact = 0.5 * voigt @ material.D() @ voigt * volumes(fam, X) * material.measure()
    assert np.allclose(energy, exact, rtol=1e-10, atol=0)


@pytest.mark.parametrize("name", list(FAMILIES))
def test_lumped_mass_adds_up_to_rho_volume(name):
    X = distorted(name)
    fam = FAMILIES[name]
    mat = MATERIALS[fam.dim][0]
    m = lumped_mass(fam, X, mat)
    assert np.all(m > 0)
    assert np.allclose(m.sum(axis=1), mat.rho * mat.measure() * volumes(fam, X), rtol=1e-12)


@pytest.mark.parametrize("name", list(FAMILIES))
def test_inverted_element_is_named(name):
    X = distorted(name, n=4)
    X[2] = X[2][:, ::-1] if FAMILIES[name].dim == 2 else X[2][:, [1, 0, 2]]   # mirror: inverted
    with pytest.raises(BadElement, match="element 2 is inverted or degenerate") as info:
        stiffness(FAMILIES[name], X, MATERIALS[FAMILIES[name].dim][0])
    assert info.value.index == 2


def test_a_cell_flat_within_rounding_is_refused_not_inverted_by_lapack():
    """Collinear tri3 nodes: the closed-form determinant is +3.5e-18, not 0; the
    cell is still refused (BadElement naming it), where np.linalg.inv would
    raise 'Singular matrix' while assembling its stiffness."""
    from solver.model.elements import FAMILIES, BadElement, lumped_mass, quadrature
    X = np.array([[[0.0, 0.0], [0.1, 0.7], [0.03, 0.21]]])
    with pytest.raises(BadElement, match="element 0 is inverted or degenerate"):
        quadrature(FAMILIES["tri3"], X)
    with pytest.raises(BadElement):
        lumped_mass(FAMILIES["tri3"], X, type("M", (), {"rho": 1.0, "measure": lambda: 1.0}))
