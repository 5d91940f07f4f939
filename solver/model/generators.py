"""Named network generators, so a 1000-DOF chain is not typed by hand.

Each returns ``Network(mass, spring_i, spring_j, stiffness, groups)`` with
``GROUND`` (-1) for a fixed spring end and ``groups`` naming node ranges
(for the log and the scene's partitions).  Pure numpy.

chain         n equal masses in a line; either end fixed or free.
metamaterial  Li et al. (2023) §4: shells 0..M+N+Q-1 in a line joined by k_n, the
              right end tied to the ground by k_n; shells M..M+N-1 each carry a
              resonator (nodes M+N+Q.. in order) on a spring k_s.  Without
              resonators it is the plain chain of Li et al. (2023) Fig. 8.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GROUND = -1


@dataclass(frozen=True)
class Network:
    mass: np.ndarray
    spring_i: np.ndarray
    spring_j: np.ndarray
    stiffness: np.ndarray
    groups: dict

    def validate(self, masses: str, springs: str):
        """Raise ValueError naming the first bad entry; ``masses`` and
        ``springs`` say where those arrays came from."""
        n = self.mass.size
        if n == 0:
            raise ValueError(f"{masses}: no nodes")
        if not np.all(self.mass > 0):
            i = int(np.argmin(self.mass > 0))
            raise ValueError(f"{masses}[{i}]: mass {self.mass[i]} must be positive")
        if not np.all(self.stiffness > 0):
            s = int(np.argmin(self.stiffness > 0))
            raise ValueError(f"{springs}[{s}]: stiffness {self.stiffness[s]} must be positive")
        for ends in (self.spring_i, self.spring_j):
            bad = (ends < GROUND) | (ends >= n)
            if bad.any():
                s = int(np.argmax(bad))
                raise ValueError(f"{springs}[{s}]: node {int(ends[s])} out of range "
                                 f"(model has {n} nodes)")


def _line(n, first=0):
    i = np.arange(first, first + n - 1)
    return i, i + 1


def chain(n: int, mass: float, stiffness: float, left: str = "fixed", right: str = "free") -> Network:
    si, sj = _line(n)
    si, sj = list(si), list(sj)
    if left == "fixed":
        si.insert(0, GROUND)
        sj.insert(0, 0)
    if right == "fixed":
        si.append(n - 1)
        sj.append(GROUND)
    return Network(np.full(n, float(mass)), np.array(si, dtype=np.int64),
                   np.array(sj, dtype=np.int64), np.full(len(si), float(stiffness)),
                   {"nodes": (0, n)})


def metamaterial(M: int, N: int, Q: int, shell_mass: float, resonator_mass: float, k_n: float,
                 k_s: float, resonators: bool = True) -> Network:
    shells = M + N + Q
    si, sj = _line(shells)
    si = np.append(si, shells - 1)               # right end tied to the ground by k_n
    sj = np.append(sj, GROUND)
    k = np.full(si.size, float(k_n))
    mass = np.full(shells, float(shell_mass))
    groups = {"shells": (0, shells)}
    if resonators:
        host = np.arange(M, M + N)
        res = np.arange(shells, shells + N)
        si = np.concatenate([si, host])
        sj = np.concatenate([sj, res])
        k = np.concatenate([k, np.full(N, float(k_s))])
        mass = np.concatenate([mass, np.full(N, float(resonator_mass))])
        groups["resonators"] = (shells, shells + N)
    return Network(mass, si.astype(np.int64), sj.astype(np.int64), k, groups)


def from_file(path: str) -> Network:
    """A network stored as NPZ or HDF5 with arrays ``mass``, ``spring_i``,
    ``spring_j`` (-1 = ground) and ``stiffness``."""
    names = ("mass", "spring_i", "spring_j", "stiffness")
    if path.endswith((".h5", ".hdf5")):
        import h5py  # lazy: h5py loads only for a model.file network (keys/schemes start fast)
        try:
            f = h5py.File(path, "r")
        except OSError as e:                   # h5py's message does not name the file
            raise ValueError(f"{path}: not an HDF5 file ({e})") from None
        with f:
            missing = [n for n in names if not isinstance(f.get(n), h5py.Dataset)]
            if missing:
                raise ValueError(f"{path}: missing datasets {missing} (has {sorted(f)})")
            data = {n: f[n][()] for n in names}
    else:
        try:
            f = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError) as e:
            raise ValueError(f"{path}: not an NPZ archive ({e})") from None
        if not isinstance(f, np.lib.npyio.NpzFile):
            raise ValueError(f"{path}: one .npy array, not an NPZ archive of {', '.join(names)} "
                             "(or an .h5/.hdf5 file)")
        with f:
            missing = [n for n in names if n not in f]
            if missing:
                raise ValueError(f"{path}: missing arrays {missing} (has {sorted(f.files)})")
            data = {n: f[n] for n in names}
    for n in names:
        a = np.asarray(data[n])
        if a.ndim != 1 or a.dtype.kind not in "iuf":
            raise ValueError(f"{path}: array {n} must be a 1-D array of numbers "
                             f"(has shape {a.shape}, dtype {a.dtype})")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{path}: array {n} has non-finite values")
        if n.startswith("spring_") and np.any(a != np.round(a)):
            raise ValueError(f"{path}: array {n} holds node ids, not whole numbers")
    net = Network(np.asarray(data["mass"], dtype=float), np.asarray(data["spring_i"], dtype=np.int64),
                  np.asarray(data["spring_j"], dtype=np.int64),
                  np.asarray(data["stiffness"], dtype=float), {"nodes": (0, len(data["mass"]))})
    if not (net.spring_i.size == net.spring_j.size == net.stiffness.size):
        raise ValueError(f"{path}: spring_i, spring_j and stiffness differ in length")
    return net


def generate(spec) -> Network:
    """The network of a scene's ``model.generator`` (a chain or a metamaterial)."""
    if spec.name == "chain":
        return chain(spec.n, spec.mass, spec.stiffness, spec.left, spec.right)
    return metamaterial(spec.M, spec.N, spec.Q, spec.shell_mass, spec.resonator_mass, spec.k_n,
                        spec.k_s, spec.resonators)
