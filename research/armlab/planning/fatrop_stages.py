r"""The optimiser's per-interval stage functions for fatrop, compiled once per robot kinematics
and variant.

:func:`armlab.planning.optimal` is a discrete optimal-control problem: each interval ``k`` of
the node grid maps a state to the next one. In fatrop's stage-wise form
(:mod:`armlab.planning.fatrop_backend`), scaled exactly as :mod:`armlab.planning.transcription`,
for the demo's variant (jerk mode, :data:`JERK`):

* state ``x_k = [q (n), qd / s_v (n), qdd / s_a (n), T_seg / s_T (1)]`` (``nx = 3n + 1``)
* input ``u_k = [qddd / s_u (n), T_next / s_T' (1)]`` (the last entry is used only at the last
  interval of a segment: the next segment's duration enters there)
* stage data ``pk_k = [c_k, b_k]``, ``c_k = s_T f_k`` (grid fraction times the duration scale),
  ``b_k = 1`` at a segment's last interval
* shared data ``pg = [s_v, s_a, s_u, tau_max, u_ref, w, t_w, pi]`` (``pi`` the inertial
  parameters, :func:`armlab.robot.symbolic.dynamic_parameters`; ``t_w`` the weight of the
  time, 0 for the ``"jerk"`` objective)

with ``h = T c`` and, exactly as the IPOPT transcription (cubic integration, Betts 2010)::

    F = [q + h qd + h^2/2 qdd + h^3/6 u, (qd + h qdd + h^2/2 u)/s_v, (qdd + h u)/s_a,
         (1 - b) T + b T_next]
    g = [tau(q, qd, qdd; pi) / tau_max, (qd + qdd h/2)/s_v, q + qd h/3, q + 2h/3 qd + h^2/6 qdd]
    l = t_w h + w h sum((u / u_ref)^2)

(the velocity and position rows are the Bernstein coefficients of the interval's quadratic and
cubic, Farouki 2012; the last one equals ``q_{k+1} - qd_{k+1} h/3`` on the dynamics) and at the
last node ``g_N = tau / tau_max``.

Other variants (:class:`Variant`, each its own library):

* **acceleration mode** (no jerk limit): ``x = [q, qd / s_v, T / s_T]``, ``u = [qdd / s_u,
  T_next]``, ``F = [q + h qd + h^2/2 u, (qd + h u)/s_v, ...]`` and the rows ``[tau(q, qd, u),
  tau(q_b, qd_b, u)] / tau_max`` (both ends of the interval, the right one ``q_b = q + h qd +
  h^2/2 u``, ``qd_b = qd + h u`` through the dynamics) and the position row ``q + qd h/2``.
* **drive rows** (``drive_limits``): the motor-envelope rows of
  :func:`armlab.planning.transcription._drive_rows` (the same function) at each constrained
  point, with its direction ``sigma`` in the stage data; the RMS row ``sum_k w_k T_m,k^2 /
  (sum T cont^2) <= 1`` couples every stage, so its numerator over ``cont^2`` is carried as
  ``n`` states ``E`` (``E_{k+1} = E_k + h/2 (T_a^2 + T_b^2) / cont^2`` in acceleration mode;
  in jerk mode the node weight ``(h_{k-1} + h_k)/2`` needs the last interval, carried as one
  more state) with the elapsed time ``t`` (``t_{k+1} = t_k + h``) and checked at the last
  node, ``E_N / t_N <= 1``. ``E`` and ``t`` are scaled by ``s_e = sum s_T``.
* **drive rows without the RMS row** (``rms=False``): the envelope rows alone, no ``E``, no
  ``t`` (what :func:`armlab.planning.fatrop_backend._fatrop` solves first).
* **fixed duration** (``duration=``, the ``"jerk"`` objective): the elapsed time as a state
  and the last node's row ``t_N = D``.
* **energy** (the ``"energy"`` objective, always with the fixed duration, with or without
  drive rows): the stage cost is the transcription's copper-loss quadrature, ``e(tau) =
  sum_i ew_i tau_i^2`` (``ew`` the energy weights
  :func:`armlab.planning.optimal_bounds._energy_weights`, appended to ``pg``): in acceleration
  mode ``l = t_w h + w h/2 (e(tau_a) + e(tau_b))`` (the interval's two ends), in jerk mode the
  trapezoid over the nodes, node ``k`` weighted ``(h_{k-1} + h_k)/2``: ``l = t_w h + w (e(tau_k)
  (h_{k-1} + h_k)/2 + e_end h)``, ``h_{k-1}`` carried as the state ``hp`` (as the RMS row's, over
  ``s_e``; ``hp_0 = 0``) and the last node's ``e_N h_{N-1}/2`` -- its state is fixed, so
  ``e_N`` is a number -- as the stage data ``e_end = e_N/2`` at the last interval (0 elsewhere).
  Its sum over the stages is the transcription's objective times ``w``.

The functions and their first and second derivatives (exact Hessian of the Lagrangian, and the
"partial" one without the torque-box rows' curvature,
:data:`armlab.planning.transcription.HESSIANS`; one Hessian with drive rows,
:attr:`Variant.one_hessian`) are generated as C by CasADi and compiled with the
robot-independent glue ``fatrop_glue.c`` (package data; the variant's sizes as ``-D`` flags)
into one shared library linked against the casadi wheel's ``libfatrop`` and ``libblasfeo``.
Inertial parameters, limits, payload, drive data, scales and grid are run-time data, so the
library depends only on the kinematic tree (:func:`armlab.robot.symbolic.kinematics_key`) and
the variant. Compile times (teachbot6, shared 2-core machine; :data:`CFLAGS_LARGE` beyond the
demo's variant) are listed in ``docs/api/planning.md``.

The library is cached on disk (:func:`cache_dir`: ``$ARMLAB_CACHE_DIR``, else
``$XDG_CACHE_HOME/armlab``, else ``~/.cache/armlab``) under a key of everything it depends on:
the kinematics hash, the variant, the casadi version, the glue's and this module's generator
version, the compiler and its flags. It is built atomically
(:func:`armlab._cache.build_library`, as the S-curve graph's): compiled in a folder beside it
and renamed, so two processes that compile at once each install a complete file and the
last rename wins. The compile prints one line on stderr before and one
after (how long). Generic flags (no ``-march=native``: a cache folder may be shared between
machines).
"""

from __future__ import annotations

import functools
import hashlib
import sys
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from armlab import _cache
from armlab._cache import CompilerUnavailable, build_library, cache_dir
from armlab._lazy import lazy_import
from armlab.errors import ArmlabError
from armlab.planning.transcription import N_DRIVE_COEFFS, _drive_rows
from armlab.robot.symbolic import kinematics_key, parametric_inverse_dynamics_function

if TYPE_CHECKING:
    import casadi as ca
else:
    ca = lazy_import("casadi")

__all__ = [
    "FatropUnavailable",
    "Variant",
    "JERK",
    "cache_dir",
    "compiled_library",
    "library_key",
    "stage_functions",
    "CFLAGS",
]

#: compiler flags of the stage library (generic: portable between machines of one arch)
CFLAGS = ("-O2", "-fPIC", "-shared")
#: the flags of the larger variants (acceleration mode, drive rows): gcc -O2 on their
#: generated functions took 5-6 x as long as -O1 (teachbot6 acc-drive: 233 s against 41 s,
#: measured on the shared 2-core machine) for solves no faster (115-137 ms against 300 ms on
#: the same case, measured)
CFLAGS_LARGE = ("-O1", "-fPIC", "-shared")
#: version of the generated functions' layout (part of the cache key)
GENERATOR_VERSION = "stages-v3"
#: the functions the glue calls, in this order
FUNCTION_NAMES = (
    "fo_eval",
    "fo_jac",
    "fo_hess",
    "fo_hess_p",
    "fo_grad",
    "fo_teval",
    "fo_tjac",
    "fo_thess",
    "fo_thess_p",
)


@dataclass(frozen=True)
class Variant:
    """Which stage library: the mode (``"jerk"`` or ``"acceleration"``), the motor-envelope
    and RMS rows (``drive``; ``rms=False``: the envelope rows without the RMS row) and the
    fixed-duration row (``duration``). Each variant is its
    own compiled library (:func:`compiled_library`): the demo's (jerk, no drive rows, no
    duration row) stays as small and as fast to compile as before."""

    mode: str = "jerk"
    drive: bool = False
    duration: bool = False
    #: the ``"energy"`` objective (copper losses, fixed duration): its own stage cost
    energy: bool = False
    rms: bool = True

    @property
    def jerk(self) -> bool:
        return self.mode == "jerk"

    @property
    def has_rms(self) -> bool:
        """The RMS row and its integral states (``drive`` with ``rms``)."""
        return self.drive and self.rms

    @property
    def elapsed(self) -> bool:
        """The elapsed time is a state (the RMS row's denominator, the duration row)."""
        return self.has_rms or self.duration

    @property
    def one_hessian(self) -> bool:
        """One Hessian function: with drive rows the "partial" Hessian (without the torque
        box's curvature) keeps the inverse dynamics' curvature through the envelope rows, so
        it costs as much as the exact one; the exact one serves both (the same KKT point).
        So with the energy objective: its cost carries the inverse dynamics' curvature in
        every stage whichever Hessian is asked for. (Without the envelope rows' curvature too,
        5 of 8 random 3-waypoint plans without the RMS row did not converge within 100
        iterations, measured.)"""
        return self.drive or self.energy

    @property
    def cflags(self) -> tuple[str, ...]:
        """The compiler flags (:data:`CFLAGS`; :data:`CFLAGS_LARGE` beyond the demo's)."""
        return CFLAGS if self == Variant() else CFLAGS_LARGE

    @property
    def tag(self) -> str:
        """Short name (file names, progress lines): ``jerk``, ``acc-drive``, ``jerk-dur``..."""
        parts = ["jerk" if self.jerk else "acc"]
        parts += ["drive"] * self.drive + ["norms"] * (self.drive and not self.rms)
        parts += ["dur"] * self.duration + ["energy"] * self.energy
        return "-".join(parts)

    def dims(self, n: int) -> dict[str, int]:
        """Sizes: state ``nx``, full input ``nu``, stage rows ``ng``, last-node rows ``ngn``,
        stage data ``npk``, the position of ``T`` in the state (``it``), the leading torque
        rows of a stage (``ntau``) and of the last node (``ntau_n``)."""
        nd = 8 * n if self.drive else 0  # envelope rows per constrained point
        if self.jerk:
            nx, ng, ngn, nsig = 3 * n + 1, 4 * n + nd, n + nd, n
        else:
            nx, ng, ngn, nsig = 2 * n + 1, 3 * n + 2 * nd, 0, 2 * n
        it = nx - 1
        if self.has_rms:
            nx += n + (1 if self.jerk else 0)  # RMS integrals (+ the last interval's h)
            ngn += n
        if self.energy and self.jerk and not self.has_rms:
            nx += 1  # the last interval's h (the energy's node weight; the RMS rows carry it)
        if self.elapsed:
            nx += 1
        if self.duration:
            ngn += 1
        npk = 2 + (nsig if self.drive else 0) + (1 if self.energy and self.jerk else 0)
        ntau, ntau_n = (n, n) if self.jerk else (2 * n, 0)
        return {
            "nx": nx, "nu": n + 1, "ng": ng, "ngn": ngn, "npk": npk, "it": it,
            "ntau": ntau, "ntau_n": ntau_n,
        }  # fmt: skip


#: the demo's variant (and every jerk-mode plan on a torque box)
JERK = Variant()


class FatropUnavailable(ArmlabError):
    """fatrop cannot be used here (no compiler, no library in the casadi wheel, a failed
    compile); :func:`armlab.planning.optimal` then solves with IPOPT and says why in
    ``stats["fallback"]``."""


def casadi_dir() -> Path:
    """The casadi package folder (``libfatrop``, ``libblasfeo`` and ``include/`` live there)."""
    return Path(ca.__file__).parent


def compiler() -> str:
    """:func:`armlab._cache.compiler`, its error as :class:`FatropUnavailable`."""
    try:
        return _cache.compiler()
    except CompilerUnavailable as exc:
        raise FatropUnavailable(f"{exc} to build the fatrop stages") from None


def check_library() -> Path:
    """The casadi folder, after checking that it holds fatrop, blasfeo and their headers."""
    d = casadi_dir()
    for need in ("libfatrop.so", "libblasfeo.so", "include/fatrop/ocp/OCPCInterface.h"):
        if not (d / need).exists():
            raise FatropUnavailable(f"the casadi wheel at {d} has no {need}")
    return d


@functools.lru_cache(maxsize=1)
def _glue_source() -> str:
    return resources.files("armlab.planning").joinpath("fatrop_glue.c").read_text()


def library_key(robot, var: Variant = JERK) -> str:
    """The cache key of ``robot``'s stage library of variant ``var``: a hash of the
    kinematics, the variant, the casadi version, the glue source, the generator version, the
    compiler and the flags."""
    h = hashlib.sha256()
    for part in (
        kinematics_key(robot),
        var.tag,
        str(robot.n_joints),
        ca.__version__,  # type: ignore[attr-defined]
        _glue_source(),
        GENERATOR_VERSION,
        compiler(),
        " ".join(var.cflags),
        sys.platform,
    ):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:20]


def _symbolic_stage(robot, var: Variant = JERK) -> dict[str, Any]:
    """The stage of ``var`` as SX expressions (module docstring)."""
    rnea = parametric_inverse_dynamics_function(robot)
    n = robot.n_joints
    dm = var.dims(n)
    SX = ca.SX
    q, vs = SX.sym("q", n), SX.sym("vs", n)
    as_ = SX.sym("as", n) if var.jerk else SX.zeros(0)
    Ts = SX.sym("Ts")
    Es = SX.sym("Es", n) if var.has_rms else SX.zeros(0)
    # h_{k-1}: the RMS row's and the energy's node weight in jerk mode
    hp = SX.sym("hp") if var.jerk and (var.has_rms or var.energy) else SX.zeros(0)
    te = SX.sym("te") if var.elapsed else SX.zeros(0)
    x = ca.vertcat(q, vs, as_, Ts, Es, hp, te)
    us, Tn = SX.sym("us", n), SX.sym("Tn")
    u = ca.vertcat(us, Tn)
    c, b = SX.sym("c"), SX.sym("b")
    sig = SX.sym("sig", n, 1 if var.jerk else 2) if var.drive else SX.zeros(n, 0)
    e_end = SX.sym("e_end") if var.energy and var.jerk else SX.zeros(0)
    pk = ca.vertcat(c, b, ca.vec(sig), e_end)
    s_v, s_a, s_u, p_tau, uref = (SX.sym(nm, n) for nm in ("s_v", "s_a", "s_u", "tau", "uref"))
    w, tw = SX.sym("w"), SX.sym("tw")
    pi = SX.sym("pi", rnea.size1_in(3))
    dc = SX.sym("dc", N_DRIVE_COEFFS * n) if var.drive else SX.zeros(0)
    eps, cont2 = (SX.sym(nm, n) if var.has_rms else SX.zeros(0) for nm in ("eps", "cont2"))
    s_e = SX.sym("s_e") if var.elapsed else SX.zeros(0)
    ew = SX.sym("ew", n) if var.energy else SX.zeros(0)
    pg = ca.vertcat(s_v, s_a, s_u, p_tau, uref, w, tw, pi, dc, eps, cont2, s_e, ew)
    h = Ts * c
    v, j = vs * s_v, us * s_u

    def drive(cols, weights):  # transcription's envelope rows and RMS numerator, one point
        return _drive_rows(cols, weights, dc, sig, eps if var.has_rms else SX.ones(n), n)

    if var.jerk:
        a = as_ * s_a
        F = [
            q + h * v + h**2 / 2 * a + h**3 / 6 * j,
            (v + h * a + h**2 / 2 * j) / s_v,
            (a + h * j) / s_a,
            (1 - b) * Ts + b * Tn,
        ]
        tau = rnea(q, v, a, pi)
        g = [tau / p_tau, (v + a * h / 2) / s_v, q + v * h / 3, q + 2 * h / 3 * v + h**2 / 6 * a]
        gN = [tau / p_tau]
        if var.drive:
            rows, tm2 = drive([(tau, v, a)], [SX(1)])
            g += [r[0] for r in rows]
            gN += [r[0] for r in rows]
        if var.has_rms:
            # trapezoid: node k stands for (h_{k-1} + h_k) / 2, h_{k-1} carried as hp
            F += [Es + (hp + h / s_e) / 2 * tm2 / cont2, h / s_e]
            gN.append((Es + hp / 2 * tm2 / cont2) / te)
        elif var.energy:
            F.append(h / s_e)  # hp: the energy's node weight needs the last interval
        if var.energy:
            # transcription's trapezoid over the nodes, node k weighted (h_{k-1} + h_k)/2
            # (h_{-1} = 0); the last node's state is fixed, its term e_N h_{N-1}/2 enters
            # the last interval through e_end = e_N/2 (stage data, 0 elsewhere)
            integral = ca.dot(ew, tau**2) * (hp * s_e + h) / 2 + e_end * h
    else:
        F = [q + h * v + h**2 / 2 * j, (v + h * j) / s_v, (1 - b) * Ts + b * Tn]
        qb, vb = q + h * v + h**2 / 2 * j, v + h * j
        tau_a, tau_b = rnea(q, v, j, pi), rnea(qb, vb, j, pi)
        g = [tau_a / p_tau, tau_b / p_tau, q + v * h / 2]
        gN = []
        if var.drive:
            rows, tm2 = drive([(tau_a, v, j), (tau_b, vb, j)], [h / 2, h / 2])
            g += [r[0] for r in rows]
        if var.has_rms:
            F.append(Es + tm2 / cont2 / s_e)
            gN.append(Es / te)
        if var.energy:  # transcription's mean of the interval's two ends
            integral = h / 2 * (ca.dot(ew, tau_a**2) + ca.dot(ew, tau_b**2))
    if var.elapsed:
        F.append(te + h / s_e)
    if var.duration:
        gN.append(te * s_e)
    if var.energy:  # the copper losses (w: 1 over the warm start's, fatrop_backend)
        cost = tw * h + w * integral
    else:
        cost = tw * h + w * h * ca.sumsqr(j / uref)
    S = {"n": n, "x": x, "u": u, "pk": pk, "pg": pg, "F": ca.vertcat(*F), "g": ca.vertcat(*g)}
    S.update(gN=ca.vertcat(*gN) if gN else SX.zeros(0), cost=cost, dims=dm)
    for key, size in (("x", dm["nx"]), ("g", dm["ng"]), ("gN", dm["ngn"]), ("pk", dm["npk"])):
        assert S[key].numel() == size, (key, S[key].numel(), size)
    return S


def stage_functions(robot, var: Variant = JERK) -> dict[str, ca.Function]:
    """The CasADi functions the glue calls (module docstring), in fatrop's ``[u; x]`` order:
    values, Jacobians stacked over their values (``[J^T; f^T]``), Lagrangian Hessians stacked
    over the Lagrangian's gradient, exact (``fo_hess``) and without the torque rows' curvature
    (``fo_hess_p``); ``fo_t*`` at the last node."""
    S = _symbolic_stage(robot, var)
    x, u, pk, pg, F, g, gN, cost = (S[k] for k in ("x", "u", "pk", "pg", "F", "g", "gN", "cost"))
    ntau, ntau_n = S["dims"]["ntau"], S["dims"]["ntau_n"]
    ux = ca.vertcat(u, x)
    d = ca.densify
    lamF, lamg, sig = ca.SX.sym("lamF", x.numel()), ca.SX.sym("lamg", g.numel()), ca.SX.sym("sig")
    lag = sig * cost + ca.dot(lamF, F) + ca.dot(lamg, g)
    lag_p = sig * cost + ca.dot(lamF, F) + ca.dot(lamg[ntau:], g[ntau:])
    grad = ca.gradient(lag, ux)
    hin = [x, u, pk, pg, lamF, lamg, sig]
    jac_F = d(ca.vertcat(ca.jacobian(F, ux).T, F.T))
    jac_g = d(ca.vertcat(ca.jacobian(g, ux).T, g.T))
    lamN = ca.SX.sym("lamN", gN.numel())
    lagN = ca.dot(lamN, gN) if gN.numel() else ca.SX(0)
    lagN_p = ca.dot(lamN[ntau_n:], gN[ntau_n:]) if gN.numel() > ntau_n else ca.SX(0)
    gradN = ca.gradient(lagN, x)
    tin = [x, pk, pg, lamN]
    fns = {
        "fo_eval": ca.Function("fo_eval", [x, u, pk, pg], [F, g, cost]),
        "fo_jac": ca.Function("fo_jac", [x, u, pk, pg], [jac_F, jac_g]),
        "fo_hess": ca.Function("fo_hess", hin, [d(ca.vertcat(ca.hessian(lag, ux)[0], grad.T))]),
        "fo_hess_p": ca.Function(
            "fo_hess_p", hin, [d(ca.vertcat(ca.hessian(lag_p, ux)[0], grad.T))]
        ),
        "fo_grad": ca.Function("fo_grad", [x, u, pk, pg], [d(ca.gradient(cost, ux))]),
        "fo_teval": ca.Function("fo_teval", [x, pk, pg], [gN]),
        "fo_tjac": ca.Function("fo_tjac", [x, pk, pg], [d(ca.vertcat(ca.jacobian(gN, x).T, gN.T))]),
        "fo_thess": ca.Function("fo_thess", tin, [d(ca.vertcat(ca.hessian(lagN, x)[0], gradN.T))]),
        "fo_thess_p": ca.Function(
            "fo_thess_p", tin, [d(ca.vertcat(ca.hessian(lagN_p, x)[0], gradN.T))]
        ),
    }
    if var.one_hessian:  # the glue calls the exact ones (-DONE_HESS)
        del fns["fo_hess_p"], fns["fo_thess_p"]
    if var != JERK:
        # casadi's common-subexpression elimination: acc-drive's Jacobian 60 k -> 35 k
        # instructions, its Hessian 102 k -> 98 k (the demo's variant stays as it was)
        fns = {
            k: ca.Function(k, f.sx_in(), f.call(f.sx_in()), {"cse": True}) for k, f in fns.items()
        }
    return fns


def _build(robot, var: Variant, so: Path, cc: str, casadi: Path) -> float:
    """Generate and compile the library into ``so`` (atomically); returns the seconds taken."""
    t0 = time.perf_counter()
    print(
        f"armlab: compiling the fatrop stage functions ({var.tag}) of {robot.name} "
        f"({robot.n_joints} joints) once for this machine into {so.parent} ...",
        file=sys.stderr,
        flush=True,
    )
    fns = stage_functions(robot, var)
    dims = var.dims(robot.n_joints)
    defs = [f"-D{k.upper()}={dims[k]}" for k in ("nx", "nu", "ng", "ngn", "npk")]
    defs += ["-DONE_HESS"] if var.one_hessian else []

    def sources(src: Path) -> list[str]:
        gen = ca.CodeGenerator(
            "fo_funcs.c",
            {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"},
        )
        for name in FUNCTION_NAMES:
            if name in fns:
                gen.add(fns[name])
        gen.generate(str(src) + "/")
        (src / "fatrop_glue.c").write_text(_glue_source())
        return [
            *var.cflags,
            f"-DNJ={robot.n_joints}",
            *defs,
            str(src / "fo_funcs.c"),
            str(src / "fatrop_glue.c"),
            f"-I{casadi / 'include'}",
            f"-L{casadi}",
            "-lfatrop",
            "-lblasfeo",
            "-lm",
            f"-Wl,-rpath,{casadi}",
        ]

    try:
        build_library(so, cc, sources, "the fatrop stages")
    except CompilerUnavailable as exc:
        raise FatropUnavailable(str(exc)) from None
    took = time.perf_counter() - t0
    print(
        f"armlab: fatrop stages ({var.tag}) compiled in {took:.1f} s ({so.name})",
        file=sys.stderr,
    )
    return took


def compiled_library(robot, var: Variant = JERK) -> tuple[Path, float]:
    """The path of ``robot``'s compiled stage library of variant ``var``, built on first use;
    and the seconds the build took (0 when it was cached).

    Raises
    ------
    FatropUnavailable
        No compiler, no fatrop in the casadi wheel, or the compile failed.
    """
    casadi = check_library()
    cc = compiler()
    so = cache_dir() / f"fatrop-stages-{var.tag}-{library_key(robot, var)}.so"
    if so.exists():
        return so, 0.0
    return so, _build(robot, var, so, cc, casadi)
