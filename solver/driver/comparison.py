"""The run compared with its reference: the modal solution, the 1D bar wave or
a monolithic run; relative errors per probe and for all probes as one vector.
"""
from __future__ import annotations

import numpy as np

from solver.driver import reference, monolithic, barwave
from solver.errors import StabilityError
from solver.model import arrays as model_mod
from solver.model import layout as overlap
from solver.partitions.partitioning import check_stability
from solver.driver.monolithic import reference_scene


def check_reference(scene):
    """Refuse an unstable monolithic reference step before the coupled run starts."""
    rscene = reference_scene(scene)
    mdl = model_mod.build(rscene)
    layouts = overlap.derive(mdl.graph(), rscene.partitions, [0])
    _, problems = check_stability(rscene, mdl, layouts, [0])
    if problems:
        raise StabilityError(f"reference.dt: {problems[0]}")


def reference_label(scene) -> str:
    ref = scene.reference
    if isinstance(ref, str):
        return ref
    if ref.kind == "bar_wave":
        return "1D bar wave (until the first reflection)"
    return f"monolithic {ref.integrator}, dt {ref.dt:g} s"


def relative_errors(x, ref):
    """(max |x - ref| / max |ref|, ||x - ref||_2 / ||ref||_2)."""
    err = np.asarray(x) - np.asarray(ref)
    scale_max = np.max(np.abs(ref))
    scale_rms = np.linalg.norm(ref)
    return (float(np.max(np.abs(err)) / scale_max) if scale_max else float(np.max(np.abs(err))),
            float(np.linalg.norm(err) / scale_rms) if scale_rms else float(np.linalg.norm(err)))


ZERO_REFERENCE = 1e-100      # a reference no larger than this is zero (denormals included)
VANISHING = 1e-3             # eq. 9 skips samples whose reference norm is below this x its peak


def add_reference(result, mdl, scene, comm, say):
    """Reference histories at the probe times (computed on rank 0) and the errors."""
    refs = None
    if comm.rank == 0:
        t_axis = next(iter(result.probes.values()))["t"]
        if scene.reference == "modal":
            dofs = [int(mdl.dofmap.offsets[p.node]) + p.component for p in scene.probes]
            u_ref, _ = reference.modal(mdl, dofs, t_axis, damping=scene.damping)
            refs = {p.name: u_ref[:, i] for i, p in enumerate(scene.probes)}
        elif getattr(scene.reference, "kind", "") == "bar_wave":
            refs = {}
            for p in scene.probes:
                x = float(mdl.points[p.node][0])
                u, _, valid = barwave.history(scene, t_axis, x)
                refs[p.name] = np.where(valid, u, np.nan)
                sig, _ = barwave.stress(scene, t_axis, x)
                refs[f"{p.name} stress"] = np.where(valid, sig, np.nan)
        else:
            refs = monolithic.history(scene, t_axis, say)
    refs = comm.bcast(refs)
    for probe in scene.probes:
        pr = result.probes[probe.name]
        ref = refs[probe.name]
        pr["reference_displacement"] = ref
        ok = np.isfinite(ref)                 # bar_wave: only until the first reflection
        if f"{probe.name} stress" in refs and "stress" in pr and probe.component == 0:
            mat = scene.model.material
            pr["reference_stress"] = refs[f"{probe.name} stress"]
            arrive, peak = barwave.stress_errors(pr["t"], pr["stress"], pr["reference_stress"], ok,
                                                 float(mdl.points[probe.node][0]),
                                                 np.sqrt(mat.E / mat.rho))
            pr["attrs"].update(stress_arrival_error=arrive, stress_peak_error=peak)
        x, r = pr["displacement"][ok], ref[ok]
        scale = float(np.max(np.abs(r))) if r.size else 0.0
        if scale <= ZERO_REFERENCE:
            # nothing to be relative to (the wave has not reached the probe):
            # say so, and give the absolute error
            pr["attrs"].update(max_rel_error=np.nan, rms_rel_error=np.nan, reference_zero=True,
                               max_abs_error=float(np.max(np.abs(x - r))) if r.size else 0.0)
        else:
            mx, rms = relative_errors(x, r)
            pr["attrs"].update(max_rel_error=mx, rms_rel_error=rms)
    if len(scene.probes) > 1:
        result.attrs["vector_rel_error"] = vector_error(
            np.array([result.probes[p.name]["displacement"] for p in scene.probes]),
            np.array([refs[p.name] for p in scene.probes]))


def vector_error(x, ref) -> float:
    """Ma et al. (2018) eq. 9 with all probes as one vector u(t_i): the mean over the
    samples of ||u(t_i) - u_ref(t_i)|| / ||u_ref(t_i)|| (samples where the
    reference is undefined are skipped: a bar wave's reference ends at the first
    reflection; so are those where it is below VANISHING x its largest norm,
    where a relative error measures a wave front's numerical precursor, not the
    solution: on wave_bar_fem's probes one sample at 1e-6 of the peak would
    give 2.9 of a mean of 3.3).  x, ref: [n_probes, n_samples]."""
    ok = np.all(np.isfinite(ref), axis=0)
    ref = np.where(ok, ref, 0.0)
    norm = np.linalg.norm(ref, axis=0)
    ok &= norm > max(VANISHING * norm.max(), 1e-300)
    if not ok.any():
        return float("nan")
    return float(np.mean(np.linalg.norm(x - ref, axis=0)[ok] / norm[ok]))


