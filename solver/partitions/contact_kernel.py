"""The compiled contact loops (numba): one pass over the candidate pairs for
the contact forces, one over the touching pairs for the dashpots and friction.

The same arithmetic as the numpy path of
:class:`solver.partitions.contact.Contact` (tests/test_contact_history.py
checks the two agree to round-off), which gathers, multiplies and scatters
over arrays of pairs: here each pair is read once and its force added to its
two rows (rows >= ``rows`` are not this piece's; the pairs come sorted by
their first particle, so its row is read in order: summing a particle's run
of pairs in a buffer first was slower, a particle having 2.3 candidates on
average, and the test for a new run mispredicted).  What later
calls need of the evaluation is kept per candidate pair and no more: whether
it touches and, if it does, its separation d = x_j - x_i (which is also the
last separation the shear history advances from; rotating particles: and
the pair's sum and difference of rotations), its distance and whether its
shear spring sticks; the normal force and stiffness and the spring's force
are recomputed from them.  The search (:func:`pairs_within`) is a cell list
with a half stencil.
``law``: 0 linear (f = s d), 1 hertz (f = s d^1.5): the codes of
:data:`solver.partitions.contact.KERNEL_LAWS`; see solver.laws.
benchmarks/bench_granular.py measures both paths against LAMMPS.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _law(law, stiff, overlap):
    """(force, tangent stiffness, energy) of the normal law at ``overlap``."""
    if law == 0:
        return stiff * overlap, stiff, 0.5 * stiff * overlap * overlap
    root = np.sqrt(overlap)
    return stiff * overlap * root, 1.5 * stiff * root, 0.4 * stiff * overlap * overlap * root


@numba.njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _turn_in(xi, p, first, count, d, inv, add):
    """xi[p, first:first + count] turned into the plane normal to d[p] (1 /
    |d[p]| = ``inv``), its length kept, plus the part of ``add`` in that
    plane: a spring that turns with its contact and grows by the change."""
    proj = 0.0
    held = 0.0
    add_n = 0.0
    for c in range(count):
        proj += xi[p, first + c] * d[p, c]
        held += xi[p, first + c] * xi[p, first + c]
        add_n += add[c] * d[p, c]
    proj *= inv
    add_n *= inv
    left = held - proj * proj
    scale = np.sqrt(held / left) if left > 0.0 else 0.0
    for c in range(count):
        n = d[p, c] * inv
        xi[p, first + c] = (xi[p, first + c] - proj * n) * scale + (add[c] - add_n * n)


def loops(dim: int):
    """(contact_forces, contact_viscous) compiled for ``dim`` components: a
    constant the compiler unrolls the component loops with (each dimension
    compiles and caches its own)."""

    @numba.njit(cache=True, nogil=True, boundscheck=False)
    def contact_forces(pi, pj, bond, alive, rest, u, radius, law, stiff, history, ratio, mu, xi,
                       live, touch, d, dist, sticks, out, rows, owned, rotary, rolling):
        """Add the contact forces of the candidate pairs (pi, pj), sorted by pi,
        at displacements ``u`` (positions X + u; ``rest``: X_j - X_i per pair, or
        an empty array when ``u`` holds positions; ``bond``: each pair's bond or
        -1, an empty array when there are none) to ``out``; returns (energy,
        dissipated by the shear springs: the energy the Coulomb cap takes from
        a sliding spring and the last energy of one that lets go), this
        piece's shares (half per end below ``owned``).
        ``d`` holds each touching pair's separation of the last call and
        receives this call's (a pair that does not touch keeps its last); with
        ``history`` the shear displacements ``xi`` of the pairs ``live``
        (touching at the last call) advance from it to this call.
        ``rotary``: the rotations per particle (2D 1, 3D 3, else 0): columns
        ``dim`` on of ``u`` and ``out`` are each particle's rotations and
        torques, the ``rotary`` columns of ``d`` after the separation each
        pair's sum theta_i + theta_j of rotations at the last call, the next
        ones their difference; the contact point, half way between the
        centres, rolls by -l (dtheta_i + dtheta_j) x n (l = r / 2) and the
        shear force's moment -l n x f acts on both particles.  With
        ``rolling`` mu_r > 0 (and ``history``) a rolling spring k_r = k_t R*^2
        (R* = r_i r_j / (r_i + r_j), ``radius`` each particle's radius r) on the
        relative rotation phi (columns ``dim`` on of
        ``xi``) since the contact began (3D: its tangential part, turned with
        the contact) turns i by -k_r phi and j by k_r phi, |k_r phi| at most
        mu_r R* f_n (beyond it rolls, the energy the cap takes
        dissipated)."""
        with_rest = rest.shape[0] > 0
        with_bonds = bond.shape[0] > 0
        energy = 0.0
        slipped = 0.0
        step = np.zeros(dim)
        turned = np.zeros(3)                       # the pair's rotations since the last call
        twist3 = np.zeros(3)                       # ... and relative rotation
        roll3 = np.zeros(3)                        # (3D) the contact point's roll
        for p in range(pi.size):
            a, b = pi[p], pj[p]
            two_r = radius[a] + radius[b]
            s = 0.0
            for c in range(dim):
                x = u[b, c] - u[a, c]
                if with_rest:
                    x += rest[p, c]
                step[c] = x
                s += x * x
            apart = s >= two_r * two_r             # (no root for the pairs apart)
            r = 0.0 if apart else np.sqrt(s)
            overlap = two_r - r
            if apart or r <= 0.0 or (with_bonds and bond[p] >= 0 and alive[bond[p]]):
                touch[p] = False               # (d keeps the pair's last touching state)
                if history and live[p]:        # the spring's last energy is let go
                    live[p] = False
                    r_old = 0.0
                    held = 0.0
                    for c in range(dim):
                        r_old += d[p, c] * d[p, c]
                        held += xi[p, c] * xi[p, c]
                    arm = radius[a] * radius[b] / two_r
                    for c in range(rotary):        # and the rolling spring's, k_r = k_t R*^2
                        held += arm * arm * xi[p, dim + c] * xi[p, dim + c]
                    _, k_old, _ = _law(law, stiff, max(two_r - np.sqrt(r_old), 0.0))
                    share = 0.5 * ((1.0 if a < owned else 0.0) + (1.0 if b < owned else 0.0))
                    slipped += share * 0.5 * ratio * k_old * held
                continue
            touch[p] = True
            dist[p] = r
            for c in range(dim):               # the change since the last call (if it touched)
                x = step[c]
                step[c] = x - d[p, c]
                d[p, c] = x
            for c in range(rotary):            # the pair's rotations since the last call
                spin = u[a, dim + c] + u[b, dim + c]
                turned[c] = spin - d[p, dim + c]
                d[p, dim + c] = spin
                twist = u[a, dim + c] - u[b, dim + c]
                twist3[c] = twist - d[p, dim + rotary + c]
                d[p, dim + rotary + c] = twist
            inv = 1.0 / r
            f, kp, e = _law(law, stiff, overlap)
            share = 0.5 * ((1.0 if a < owned else 0.0) + (1.0 if b < owned else 0.0))
            shrink = 0.0
            kt = ratio * kp
            if history:
                length2 = 0.0
                if live[p]:        # xi turned into the tangent plane, plus the
                    _turn_in(xi, p, 0, dim, d, inv, step)   # separation change's part
                    if rotary == 1:    # rolled by -l (dtheta_i + dtheta_j) x n (d carries r)
                        roll = 0.5 * turned[0]
                        xi[p, 0] += roll * d[p, 1]
                        xi[p, 1] -= roll * d[p, 0]
                    elif rotary == 3:  # about the mid separation (second order in the
                        rn = 0.0       # step), its tangential part
                        for c in range(3):
                            c1, c2 = (c + 1) % 3, (c + 2) % 3
                            roll3[c] = -0.5 * (turned[c1] * (d[p, c2] - 0.5 * step[c2]) -
                                               turned[c2] * (d[p, c1] - 0.5 * step[c1]))
                            rn += roll3[c] * d[p, c]
                        rn *= inv * inv
                        for c in range(3):
                            xi[p, c] += roll3[c] - rn * d[p, c]
                    for c in range(dim):
                        length2 += xi[p, c] * xi[p, c]
                    if rolling > 0.0 and rotary == 1:
                        xi[p, dim] += twist3[0]
                    elif rolling > 0.0:        # 3D: the same, the relative turn's part
                        _turn_in(xi, p, dim, 3, d, inv, twist3)
                else:
                    for c in range(xi.shape[1]):
                        xi[p, c] = 0.0
                cap = mu * f
                length = np.sqrt(length2)
                sticks[p] = kt * length <= cap
                shrink = 1.0
                if not sticks[p]:              # the energy the cap takes is dissipated
                    shrink = cap / (kt * length)
                    slipped += share * 0.5 * kt * length * length * (1.0 - shrink * shrink)
                    length *= shrink
                e += 0.5 * kt * length * length
                if rolling > 0.0:              # the rolling spring, capped at mu_r R* f_n
                    arm = radius[a] * radius[b] / two_r
                    kr = arm * arm * kt
                    most = rolling * arm * f / kr
                    size2 = 0.0
                    for c in range(rotary):
                        size2 += xi[p, dim + c] * xi[p, dim + c]
                    if rotary == 1 and abs(xi[p, dim]) > most:
                        slipped += share * 0.5 * kr * (size2 - most * most)
                        xi[p, dim] = most if xi[p, dim] > 0.0 else -most
                        size2 = most * most
                    elif rotary == 3 and size2 > most * most:     # its direction kept
                        slipped += share * 0.5 * kr * (size2 - most * most)
                        cut = most / np.sqrt(size2)
                        for c in range(rotary):
                            xi[p, dim + c] *= cut
                        size2 = most * most
                    e += 0.5 * kr * size2
                    for c in range(rotary):
                        moment = kr * xi[p, dim + c]   # -moment on i, +moment on j
                        if b < rows:
                            out[b, dim + c] += moment
                        if a < rows:
                            out[a, dim + c] -= moment
                live[p] = True
            energy += share * e
            fr = f * inv
            for c in range(dim):
                g = fr * d[p, c]
                if history:
                    x = xi[p, c] * shrink
                    xi[p, c] = x
                    g -= kt * x
                if b < rows:
                    out[b, c] += g
                if a < rows:
                    out[a, c] -= g
            if rotary == 1 and history:     # -l n x (-k_t xi) on both, l = r / 2
                torque = 0.5 * kt * (d[p, 0] * xi[p, 1] - d[p, 1] * xi[p, 0])
                if b < rows:
                    out[b, dim] += torque
                if a < rows:
                    out[a, dim] += torque
            elif rotary == 3 and history:
                for c in range(3):
                    c1, c2 = (c + 1) % 3, (c + 2) % 3
                    torque = 0.5 * kt * (d[p, c1] * xi[p, c2] - d[p, c2] * xi[p, c1])
                    if b < rows:
                        out[b, dim + c] += torque
                    if a < rows:
                        out[a, dim + c] += torque
        return energy, slipped


    @numba.njit(cache=True, nogil=True, boundscheck=False)
    def contact_viscous(pi, pj, touch, d, dist, radius, law, stiff, history, xi, sticks, mass, v,
                        zeta, mu, zeta_t, ratio, out, rows, owned, rotary):
        """Add the dashpot and friction forces of the pairs touching at the last
        :func:`contact_forces` at velocities ``v`` to ``out``; returns their
        dissipated power (this piece's share).  Without ``history`` friction is
        min(mu f_n, c_t |v_t|) against the sliding velocity; with it, a dashpot
        beside a sticking spring, the two together at most mu f_n, nothing
        beside a sliding one.  ``rotary`` (rotations per particle): the contact
        point's sliding velocity has the particles' spins' part -l (omega_i +
        omega_j) x n, and the friction's moment acts on both (as in
        :func:`contact_forces`)."""
        power = 0.0
        force = np.zeros(dim)
        vt = np.zeros(dim)
        for p in range(pi.size):
            if not touch[p]:
                continue
            a, b = pi[p], pj[p]
            ma, mb = mass[a], mass[b]
            r = dist[p]
            fn, kp, _ = _law(law, stiff, radius[a] + radius[b] - r)
            root = np.sqrt(kp * ma * mb / (ma + mb))
            vn = 0.0
            for c in range(dim):
                vn += (v[b, c] - v[a, c]) * d[p, c]
            vn /= r
            pw = 0.0
            for c in range(dim):
                force[c] = 0.0
            if zeta != 0.0:
                cn = 2.0 * zeta * root
                for c in range(dim):
                    force[c] -= cn * vn * d[p, c] / r
                pw += cn * vn * vn
            if mu != 0.0:
                speed = 0.0
                for c in range(dim):
                    vt[c] = (v[b, c] - v[a, c]) - vn * d[p, c] / r
                if rotary == 1:
                    roll = 0.5 * (v[a, dim] + v[b, dim])     # l (omega_i + omega_j) / r
                    vt[0] += roll * d[p, 1]
                    vt[1] -= roll * d[p, 0]
                elif rotary == 3:                            # -(omega_i + omega_j) x d / 2
                    for c in range(3):
                        c1, c2 = (c + 1) % 3, (c + 2) % 3
                        vt[c] -= 0.5 * ((v[a, dim + c1] + v[b, dim + c1]) * d[p, c2] -
                                        (v[a, dim + c2] + v[b, dim + c2]) * d[p, c1])
                for c in range(dim):
                    speed += vt[c] * vt[c]
                speed = np.sqrt(speed)
                if not history:
                    ft = min(mu * fn, 2.0 * zeta_t * root * speed)
                elif sticks[p]:
                    held = 0.0
                    for c in range(dim):
                        held += xi[p, c] * xi[p, c]
                    room = max(mu * fn - ratio * kp * np.sqrt(held), 0.0)
                    ft = min(room, 2.0 * zeta_t * np.sqrt(ratio) * root * speed)
                else:
                    ft = 0.0
                if speed > 0.0:
                    for c in range(dim):
                        force[c] -= ft / speed * vt[c]
                    if rotary == 1:        # -l n x f_t on both
                        torque = 0.5 * ft / speed * (d[p, 0] * vt[1] - d[p, 1] * vt[0])
                        if b < rows:
                            out[b, dim] += torque
                        if a < rows:
                            out[a, dim] += torque
                    elif rotary == 3:
                        for c in range(3):
                            c1, c2 = (c + 1) % 3, (c + 2) % 3
                            torque = 0.5 * ft / speed * (d[p, c1] * vt[c2] - d[p, c2] * vt[c1])
                            if b < rows:
                                out[b, dim + c] += torque
                            if a < rows:
                                out[a, dim + c] += torque
                pw += ft * speed
            for c in range(dim):
                if b < rows:
                    out[b, c] += force[c]
                if a < rows:
                    out[a, c] -= force[c]
            power += 0.5 * ((1.0 if a < owned else 0.0) + (1.0 if b < owned else 0.0)) * pw
        return power

    return contact_forces, contact_viscous


LOOPS = {2: loops(2), 3: loops(3)}


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _cells(x, reach):
    """Cells of side >= ``reach`` over the points ``x``, with a layer of empty
    cells around them (a neighbour of an occupied cell is always a cell):
    (first point of each cell in ``order``, the points by cell, cells per
    axis)."""
    n, dim = x.shape
    lo = np.empty(dim)
    hi = np.empty(dim)
    for c in range(dim):
        lo[c] = x[:, c].min()
        hi[c] = x[:, c].max()
    side = reach
    total = 1.0
    for c in range(dim):
        total *= (hi[c] - lo[c]) / side + 1.0
    if total > 4.0 * n + 64.0:                 # sparse points: larger cells, bounded memory
        side *= (total / (4.0 * n + 64.0)) ** (1.0 / dim)
    shape = np.empty(dim, np.int64)
    for c in range(dim):
        shape[c] = int((hi[c] - lo[c]) / side) + 3
    cell = np.empty(n, np.int64)
    for p in range(n):
        at = 0
        for c in range(dim):
            at = at * shape[c] + min(int((x[p, c] - lo[c]) / side), shape[c] - 3) + 1
        cell[p] = at
    n_cells = 1
    for c in range(dim):
        n_cells *= shape[c]
    start = np.zeros(n_cells + 1, np.int64)
    for p in range(n):
        start[cell[p] + 1] += 1
    for q in range(n_cells):
        start[q + 1] += start[q]
    fill = start[:-1].copy()
    order = np.empty(n, np.int64)
    for p in range(n):
        order[fill[cell[p]]] = p
        fill[cell[p]] += 1
    return start, order, shape


def _ahead(shape):
    """The index steps to a cell's own cell and the (3^dim - 1) / 2 neighbour
    cells ahead of it (first nonzero offset +1) in the grid of ``shape``."""
    dim = len(shape)
    stride = np.cumprod(np.concatenate([[1], np.asarray(shape[1:], np.int64)[::-1]]))[::-1]
    offsets = np.stack(np.meshgrid(*([np.arange(-1, 2)] * dim), indexing="ij"), -1)
    offsets = offsets.reshape(-1, dim)
    lead = np.array([o[np.flatnonzero(o)[0]] if o.any() else 0 for o in offsets])
    return np.concatenate([[0], offsets[lead > 0] @ stride]).astype(np.int64)


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _near(xs, reach, start, order, delta, found):
    """The pairs of points within ``reach`` into ``found`` (smaller index
    first), each met once: each cell's points against the later points of
    their cell and every point of the cells ``delta`` ahead of it (a half
    stencil; the empty layer of :func:`_cells` keeps every neighbour
    inside), read in cell order (``xs``: the points by cell).  Returns their
    count, or -1 when ``found`` is too small."""
    dim = xs.shape[1]
    r2 = reach * reach
    k = 0
    for cell in range(start.size - 1):
        lo, hi = start[cell], start[cell + 1]
        if lo == hi:
            continue
        for side in range(delta.size):
            other = cell + delta[side]
            o_lo, o_hi = start[other], start[other + 1]
            for s in range(lo, hi):
                for t in range(s + 1 if side == 0 else o_lo, o_hi):
                    d2 = 0.0
                    for c in range(dim):
                        e = xs[t, c] - xs[s, c]
                        d2 += e * e
                    if d2 <= r2:
                        if k == found.shape[0]:
                            return -1
                        p, q = order[s], order[t]
                        found[k, 0] = min(p, q)
                        found[k, 1] = max(p, q)
                        k += 1
    return k


@numba.njit(cache=True, nogil=True, boundscheck=False)
def _by_first(found, n):
    """The pairs ``found`` sorted by their first point, then their second: a
    counting sort by the first, each one's partners put in order."""
    k = found.shape[0]
    first = np.zeros(n + 1, np.int64)
    for a in range(k):
        first[found[a, 0] + 1] += 1
    for p in range(n):
        first[p + 1] += first[p]
    fill = first[:-1].copy()
    pairs = np.empty((k, 2), np.int64)
    for a in range(k):
        p = found[a, 0]
        pairs[fill[p], 0] = p
        pairs[fill[p], 1] = found[a, 1]
        fill[p] += 1
    for p in range(n):
        for a in range(first[p] + 1, first[p + 1]):
            q = pairs[a, 1]
            b = a - 1
            while b >= first[p] and pairs[b, 1] > q:
                pairs[b + 1, 1] = pairs[b, 1]
                b -= 1
            pairs[b + 1, 1] = q
    return pairs


def pairs_within(x, reach):
    """The pairs (p, q), p < q, of rows of ``x`` [n, dim] at most ``reach``
    apart, sorted by p then q: a cell list (cells of side >= reach), the
    k-d tree's query_pairs compiled for what the contact search asks."""
    x = np.ascontiguousarray(x, dtype=float)
    if len(x) < 2:
        return np.zeros((0, 2), np.int64)
    if not np.all(np.isfinite(x)):                 # (as the k-d tree refuses them)
        raise ValueError("contact search: particle positions are not finite")
    start, order, shape = _cells(x, reach)
    xs, delta = x[order], _ahead(shape)
    found = np.empty((4 * len(x) + 16, 2), np.int64)
    while (k := _near(xs, reach, start, order, delta, found)) < 0:
        found = np.empty((2 * len(found), 2), np.int64)    # a dense cluster: room and again
    return _by_first(found[:k], len(x))


@numba.njit(cache=True, nogil=True, boundscheck=False)
def carry(old_i, old_j, xi, sep, live, new_i, new_j):
    """The shear histories (xi, last separation, live) of new pairs (new_i,
    new_j) from those of old pairs (old_i, old_j), both sorted by (i, j): one
    merge; a new pair not among the old ones starts without history."""
    m, dim, width = new_i.size, xi.shape[1], sep.shape[1]
    new_xi = np.zeros((m, dim))
    new_sep = np.zeros((m, width))
    new_live = np.zeros(m, np.bool_)
    o = 0
    for p in range(m):
        a, b = new_i[p], new_j[p]
        while o < old_i.size and (old_i[o] < a or (old_i[o] == a and old_j[o] < b)):
            o += 1
        if o < old_i.size and old_i[o] == a and old_j[o] == b and live[o]:
            new_live[p] = True
            for c in range(dim):
                new_xi[p, c] = xi[o, c]
            for c in range(width):
                new_sep[p, c] = sep[o, c]
    return new_xi, new_sep, new_live


@numba.njit(cache=True, nogil=True, boundscheck=False)
def largest_move(u, nodes, built):
    """max over ``nodes`` of |u[node] - built[k]|^2 (the search's staleness)."""
    worst = 0.0
    dim = u.shape[1]
    for k in range(nodes.size):
        s = 0.0
        for c in range(dim):
            t = u[nodes[k], c] - built[k, c]
            s += t * t
        worst = max(worst, s)
    return worst
