r"""The optimiser's per-interval stage functions for fatrop, compiled once per robot kinematics.

:func:`armlab.planning.optimal` in jerk mode is a discrete optimal-control problem: each
interval ``k`` of the node grid maps a state to the next one. In fatrop's stage-wise form
(:mod:`armlab.planning.fatrop_backend`), scaled exactly as :mod:`armlab.planning.transcription`:

* state ``x_k = [q (n), qd / s_v (n), qdd / s_a (n), T_seg / s_T (1)]`` (``nx = 3n + 1``)
* input ``u_k = [qddd / s_u (n), T_next / s_T' (1)]`` (the last entry is used only at the last
  interval of a segment: the next segment's duration enters there)
* stage data ``pk_k = [c_k, b_k]``, ``c_k = s_T f_k`` (grid fraction times the duration scale),
  ``b_k = 1`` at a segment's last interval
* shared data ``pg = [s_v, s_a, s_u, tau_max, u_ref, w, pi]`` (``pi`` the inertial parameters,
  :func:`armlab.robot.symbolic.dynamic_parameters`)

with ``h = T c`` and, exactly as the IPOPT transcription (cubic integration, Betts 2010)::

    F = [q + h qd + h^2/2 qdd + h^3/6 u, (qd + h qdd + h^2/2 u)/s_v, (qdd + h u)/s_a,
         (1 - b) T + b T_next]
    g = [tau(q, qd, qdd; pi) / tau_max, (qd + qdd h/2)/s_v, q + qd h/3, q + 2h/3 qd + h^2/6 qdd]
    l = h + w h sum((u / u_ref)^2)

(the velocity and position rows are the Bernstein coefficients of the interval's quadratic and
cubic, Farouki 2012; the last one equals ``q_{k+1} - qd_{k+1} h/3`` on the dynamics) and at the
last node ``g_N = tau / tau_max``. The functions and their first and second derivatives
(exact Hessian of the Lagrangian, and the "partial" one without the torque rows' curvature,
:data:`armlab.planning.transcription.HESSIANS`) are generated as C by CasADi and compiled with
the robot-independent glue ``fatrop_glue.c`` (package data) into one shared library linked
against the casadi wheel's ``libfatrop`` and ``libblasfeo``. Inertial parameters, limits,
payload, scales and grid are run-time data, so the library depends only on the kinematic tree
(:func:`armlab.robot.symbolic.kinematics_key`).

The library is cached on disk (:func:`cache_dir`: ``$ARMLAB_CACHE_DIR``, else
``$XDG_CACHE_HOME/armlab``, else ``~/.cache/armlab``) under a key of everything it depends on:
the kinematics hash, the casadi version, the glue's and this module's generator version, the
compiler and its flags. It is written atomically (:func:`armlab.io.atomic.atomic_write`): two
processes that compile at once each write a complete file and the last rename wins. The
compile prints one line on stderr before and one after (how long). Generic ``-O2`` (no
``-march=native``: a cache folder may be shared between machines).
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import time
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from armlab._lazy import lazy_import
from armlab.errors import ArmlabError
from armlab.io.atomic import atomic_write
from armlab.robot.symbolic import kinematics_key, parametric_inverse_dynamics_function

if TYPE_CHECKING:
    import casadi as ca
else:
    ca = lazy_import("casadi")

__all__ = [
    "FatropUnavailable",
    "cache_dir",
    "compiled_library",
    "library_key",
    "stage_functions",
    "CFLAGS",
]

#: compiler flags of the stage library (generic: portable between machines of one arch)
CFLAGS = ("-O2", "-fPIC", "-shared")
#: version of the generated functions' layout (part of the cache key)
GENERATOR_VERSION = "jerk-v1"
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


class FatropUnavailable(ArmlabError):
    """fatrop cannot be used here (no compiler, no library in the casadi wheel, a failed
    compile); :func:`armlab.planning.optimal` then solves with IPOPT and says why in
    ``stats["fallback"]``."""


def cache_dir() -> Path:
    """The folder of armlab's compiled artefacts: ``$ARMLAB_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/armlab``, else ``~/.cache/armlab``."""
    own = os.environ.get("ARMLAB_CACHE_DIR")
    if own:
        return Path(own).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "armlab"


def casadi_dir() -> Path:
    """The casadi package folder (``libfatrop``, ``libblasfeo`` and ``include/`` live there)."""
    return Path(ca.__file__).parent


def compiler() -> str:
    """The C compiler: ``$CC`` if set, else ``gcc`` or ``cc`` on the path.

    Raises
    ------
    FatropUnavailable
        None found (``$CC`` set to a missing program included).
    """
    cc = os.environ.get("CC")
    names = [cc] if cc else ["gcc", "cc"]
    for name in names:
        found = shutil.which(name)
        if found:
            return found
    raise FatropUnavailable(
        f"no C compiler ({'CC=' + cc if cc else 'gcc or cc'} not found) to build the fatrop stages"
    )


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


def library_key(robot) -> str:
    """The cache key of ``robot``'s stage library: a hash of the kinematics, the casadi
    version, the glue source, the generator version, the compiler and the flags."""
    h = hashlib.sha256()
    for part in (
        kinematics_key(robot),
        str(robot.n_joints),
        ca.__version__,  # type: ignore[attr-defined]
        _glue_source(),
        GENERATOR_VERSION,
        compiler(),
        " ".join(CFLAGS),
        sys.platform,
    ):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:20]


def _symbolic_stage(robot) -> tuple[dict[str, Any], Any, Any]:
    rnea = parametric_inverse_dynamics_function(robot)
    n = robot.n_joints
    SX = ca.SX
    q, vs, as_ = SX.sym("q", n), SX.sym("vs", n), SX.sym("as", n)
    Ts = SX.sym("Ts")
    x = ca.vertcat(q, vs, as_, Ts)
    us, Tn = SX.sym("us", n), SX.sym("Tn")
    u = ca.vertcat(us, Tn)
    c, b = SX.sym("c"), SX.sym("b")
    s_v, s_a, s_u, p_tau, uref = (SX.sym(nm, n) for nm in ("s_v", "s_a", "s_u", "tau", "uref"))
    w = SX.sym("w")
    pi = SX.sym("pi", rnea.size1_in(3))
    pg = ca.vertcat(s_v, s_a, s_u, p_tau, uref, w, pi)
    h = Ts * c
    v, a, j = vs * s_v, as_ * s_a, us * s_u
    F = ca.vertcat(
        q + h * v + h**2 / 2 * a + h**3 / 6 * j,
        (v + h * a + h**2 / 2 * j) / s_v,
        (a + h * j) / s_a,
        (1 - b) * Ts + b * Tn,
    )
    tau = rnea(q, v, a, pi) / p_tau
    g = ca.vertcat(tau, (v + a * h / 2) / s_v, q + v * h / 3, q + 2 * h / 3 * v + h**2 / 6 * a)
    cost = h + w * h * ca.sumsqr(j / uref)
    return {"n": n, "x": x, "u": u, "pk": ca.vertcat(c, b), "pg": pg, "F": F, "g": g}, tau, cost


def stage_functions(robot) -> dict[str, ca.Function]:
    """The CasADi functions the glue calls (module docstring), in fatrop's ``[u; x]`` order:
    values, Jacobians stacked over their values (``[J^T; f^T]``), Lagrangian Hessians stacked
    over the Lagrangian's gradient, exact (``fo_hess``) and without the torque rows' curvature
    (``fo_hess_p``); ``fo_t*`` at the last node."""
    S, tau, cost = _symbolic_stage(robot)
    x, u, pk, pg, F, g, n = S["x"], S["u"], S["pk"], S["pg"], S["F"], S["g"], S["n"]
    ux = ca.vertcat(u, x)
    d = ca.densify
    lamF, lamg, sig = ca.SX.sym("lamF", x.numel()), ca.SX.sym("lamg", g.numel()), ca.SX.sym("sig")
    lag = sig * cost + ca.dot(lamF, F) + ca.dot(lamg, g)
    lag_p = sig * cost + ca.dot(lamF, F) + ca.dot(lamg[n:], g[n:])
    grad = ca.gradient(lag, ux)
    hin = [x, u, pk, pg, lamF, lamg, sig]
    jac_F = d(ca.vertcat(ca.jacobian(F, ux).T, F.T))
    jac_g = d(ca.vertcat(ca.jacobian(g, ux).T, g.T))
    lamN = ca.SX.sym("lamN", n)
    lagN = ca.dot(lamN, tau)
    gradN = ca.gradient(lagN, x)
    nx = x.numel()
    return {
        "fo_eval": ca.Function("fo_eval", [x, u, pk, pg], [F, g, cost]),
        "fo_jac": ca.Function("fo_jac", [x, u, pk, pg], [jac_F, jac_g]),
        "fo_hess": ca.Function("fo_hess", hin, [d(ca.vertcat(ca.hessian(lag, ux)[0], grad.T))]),
        "fo_hess_p": ca.Function(
            "fo_hess_p", hin, [d(ca.vertcat(ca.hessian(lag_p, ux)[0], grad.T))]
        ),
        "fo_grad": ca.Function("fo_grad", [x, u, pk, pg], [d(ca.gradient(cost, ux))]),
        "fo_teval": ca.Function("fo_teval", [x, pg], [tau]),
        "fo_tjac": ca.Function("fo_tjac", [x, pg], [d(ca.vertcat(ca.jacobian(tau, x).T, tau.T))]),
        "fo_thess": ca.Function(
            "fo_thess", [x, pg, lamN], [d(ca.vertcat(ca.hessian(lagN, x)[0], gradN.T))]
        ),
        "fo_thess_p": ca.Function(
            "fo_thess_p", [x, pg, lamN], [d(ca.vertcat(ca.SX.zeros(nx, nx), gradN.T))]
        ),
    }


def _build(robot, so: Path, cc: str, casadi: Path) -> float:
    """Generate and compile the library into ``so`` (atomically); returns the seconds taken."""
    t0 = time.perf_counter()
    print(
        f"armlab: compiling the fatrop stage functions of {robot.name} ({robot.n_joints} joints) "
        f"once for this machine into {so.parent} ...",
        file=sys.stderr,
        flush=True,
    )
    fns = stage_functions(robot)
    with tempfile.TemporaryDirectory(prefix="armlab-fatrop-") as tmp:
        src = Path(tmp)
        gen = ca.CodeGenerator(
            "fo_funcs.c",
            {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"},
        )
        for name in FUNCTION_NAMES:
            gen.add(fns[name])
        gen.generate(str(src) + "/")
        (src / "fatrop_glue.c").write_text(_glue_source())
        out = src / "stages.so"
        cmd = [
            cc,
            *CFLAGS,
            f"-DNJ={robot.n_joints}",
            str(src / "fo_funcs.c"),
            str(src / "fatrop_glue.c"),
            f"-I{casadi / 'include'}",
            f"-L{casadi}",
            "-lfatrop",
            "-lblasfeo",
            "-lm",
            f"-Wl,-rpath,{casadi}",
            "-o",
            str(out),
        ]
        try:
            r = subprocess.run(cmd, capture_output=True, text=True, check=False)
        except OSError as exc:
            raise FatropUnavailable(f"the C compiler {cc} could not run: {exc}") from None
        if r.returncode:
            last = (r.stderr.strip().splitlines() or ["(no message)"])[-1]
            raise FatropUnavailable(f"compiling the fatrop stages failed: {last}")
        so.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(so, out.read_bytes())
    took = time.perf_counter() - t0
    print(f"armlab: fatrop stages compiled in {took:.1f} s ({so.name})", file=sys.stderr)
    return took


def compiled_library(robot) -> tuple[Path, float]:
    """The path of ``robot``'s compiled stage library, built on first use; and the seconds
    the build took (0 when it was cached).

    Raises
    ------
    FatropUnavailable
        No compiler, no fatrop in the casadi wheel, or the compile failed.
    """
    casadi = check_library()
    cc = compiler()
    so = cache_dir() / f"fatrop-stages-{library_key(robot)}.so"
    if so.exists():
        return so, 0.0
    return so, _build(robot, so, cc, casadi)
