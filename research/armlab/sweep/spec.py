"""The sweep file: a base study and the study keys to vary.

Format (TOML)::

    [sweep]
    name = "payload vs gear ratio"
    study = "demo"           # the base study: "demo" (built-in) or a STUDY.toml path, relative
                             # to this file
    mode = "grid"            # "grid" (every combination), "random" or "lhs" (Latin hypercube)
    samples = 16             # random / lhs: number of parameter sets
    seed = 0                 # random / lhs: the draw is reproducible from the file
    figures = ["duration_s"] # key figures (study.figures.key_figures) plotted vs each parameter
    retries = 2              # resubmissions of a set whose worker died (beyond Dask's own)
    rerun_errors = false     # a re-run also repeats the sets that ended in an error

    [set]                    # fixed changes to the base study for every set (dotted keys)
    "study.stages" = ["kinematics", "plan"]

    [[parameter]]
    key = "payload.mass_kg"  # any study key (armlab.study.spec.check_key)
    values = [0.0, 0.5, 1.0] # explicit values (numbers or strings, e.g. motor names) ...

    [[parameter]]
    key = "drives.joint2.ratio"
    low = 300                # ... or a range: grid takes `num` values from low to high
    high = 500               #     (geometric spacing if log = true); random / lhs draw
    num = 3                  #     uniformly (log-uniformly) in [low, high]; integer = true
    log = false              #     rounds to integers

Each parameter set is identified by the first 16 hex digits of the sha256 of its canonical JSON
(sorted keys): re-running a sweep recognises what is done whatever the order.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from armlab.errors import SpecError
from armlab.study.spec import (
    apply_overrides,
    check_key,
    demo_study_path,
    document_hash,
    read_study_document,
)
from armlab.tomlfile import read_toml

__all__ = [
    "Parameter",
    "SweepSpec",
    "demo_sweep_path",
    "load_sweep",
    "parse_sweep",
    "parameter_sets",
    "parameter_key",
    "definition_sha256",
    "MODES",
]

MODES = ("grid", "random", "lhs")


@dataclass(frozen=True)
class Parameter:
    """One varied study key: explicit ``values`` or a range ``[low, high]``."""

    key: str
    values: tuple[Any, ...] | None = None
    low: float | None = None
    high: float | None = None
    num: int | None = None
    log: bool = False
    integer: bool = False

    def grid(self) -> list[Any]:
        """The values a grid takes."""
        if self.values is not None:
            return list(self.values)
        low, high = self._range()
        assert self.num is not None  # parse_sweep requires num for a grid range
        f = np.geomspace if self.log else np.linspace
        return [self._cast(x) for x in f(low, high, self.num)]

    def from_unit(self, u: float) -> Any:
        """The value at quantile ``u`` in [0, 1) (random and Latin-hypercube draws)."""
        if self.values is not None:
            return self.values[min(int(u * len(self.values)), len(self.values) - 1)]
        low, high = self._range()
        if self.log:
            x = math.exp(math.log(low) + u * (math.log(high) - math.log(low)))
        else:
            x = low + u * (high - low)
        return self._cast(x)

    def _range(self) -> tuple[float, float]:
        """``(low, high)`` of a range parameter (``values`` is None: parse_sweep set both)."""
        assert self.low is not None and self.high is not None
        return self.low, self.high

    def _cast(self, x: float) -> Any:
        return int(round(x)) if self.integer else float(x)

    @property
    def categorical(self) -> bool:
        return self.values is not None and any(isinstance(v, str) for v in self.values)


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep.

    ``study_document`` is the base study with ``[set]`` applied, ``study_dir`` the folder its
    relative paths refer to, ``study_hash`` the sha256 of that document (a results folder holds
    the rows of one base study only), ``study_file`` the file it was read from (the built-in
    demo's for ``study = "demo"``; its sha256 goes into ``sweep.json``).
    """

    name: str
    mode: str
    parameters: tuple[Parameter, ...]
    samples: int | None
    seed: int
    figures: tuple[str, ...]
    retries: int
    rerun_errors: bool
    study_document: dict[str, Any]
    study_dir: Path
    study_source: str
    study_hash: str
    fixed: dict[str, Any] = field(default_factory=dict)
    source: str = "<dict>"
    study_file: Path | None = None

    @property
    def parameter_keys(self) -> list[str]:
        return [p.key for p in self.parameters]


_SWEEP_KEYS = ("name", "study", "mode", "samples", "seed", "figures", "retries", "rerun_errors")
_PARAM_KEYS = ("key", "values", "low", "high", "num", "log", "integer")


def _number(v, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise SpecError(f"{where}: expected a finite number, not {v!r}")
    return float(v)


def _parse_parameter(t: Any, where: str, mode: str) -> Parameter:
    if not isinstance(t, dict):
        raise SpecError(f"{where}: expected a table [[parameter]], not {t!r}")
    unknown = sorted(set(t) - set(_PARAM_KEYS))
    if unknown:
        raise SpecError(f"{where}.{unknown[0]}: unknown key (known: {', '.join(_PARAM_KEYS)})")
    key = t.get("key")
    if not isinstance(key, str):
        raise SpecError(f"{where}.key: missing (the dotted study key to vary)")
    check_key(key)
    for flag in ("log", "integer"):
        if not isinstance(t.get(flag, False), bool):
            raise SpecError(f"{where}.{flag}: expected true or false, not {t[flag]!r}")
    if "values" in t:
        extra = [k for k in ("low", "high", "num", "log") if k in t]
        if extra:
            raise SpecError(f"{where}.{extra[0]}: give either values or low/high, not both")
        vals = t["values"]
        if not isinstance(vals, list) or not vals:
            raise SpecError(f"{where}.values: expected a non-empty list, not {vals!r}")
        for i, v in enumerate(vals):
            if isinstance(v, (dict, list)):
                raise SpecError(f"{where}.values[{i}]: expected a number or a string, not {v!r}")
        if len({isinstance(v, str) for v in vals}) > 1:
            raise SpecError(f"{where}.values: mixes strings and numbers")
        if len({json.dumps(v) for v in vals}) != len(vals):
            raise SpecError(f"{where}.values: a value is repeated")
        return Parameter(key=key, values=tuple(vals), integer=bool(t.get("integer", False)))
    if "low" not in t or "high" not in t:
        raise SpecError(f"{where}.values: give values = [...] or low and high")
    low, high = _number(t["low"], f"{where}.low"), _number(t["high"], f"{where}.high")
    if not low < high:
        raise SpecError(f"{where}.high: must be greater than low ({low!r})")
    log = bool(t.get("log", False))
    if log and low <= 0:
        raise SpecError(f"{where}.low: must be > 0 with log = true")
    num = t.get("num")
    if mode == "grid":
        if isinstance(num, bool) or not isinstance(num, int) or num < 2:
            raise SpecError(f"{where}.num: a grid range needs num >= 2 values, not {num!r}")
    return Parameter(
        key=key, low=low, high=high, num=num, log=log, integer=bool(t.get("integer", False))
    )


def parse_sweep(
    document: dict[str, Any], *, base_dir: str | Path = ".", source: str = "<dict>"
) -> SweepSpec:
    """Validate a sweep document (as ``tomllib`` returns it); the base study is read too.

    Raises
    ------
    SpecError
        Unknown table or key, a parameter key that is not a study key, empty or repeated
        values, a bad range; or the base study itself is invalid (its keys, not the varied
        values: those are checked per parameter set when it runs).
    """
    unknown = sorted(set(document) - {"sweep", "set", "parameter"})
    if unknown:
        raise SpecError(f"{unknown[0]}: unknown table (known: sweep, set, parameter)")
    sw = document.get("sweep", {})
    if not isinstance(sw, dict):
        raise SpecError("sweep: expected a table [sweep]")
    unknown = sorted(set(sw) - set(_SWEEP_KEYS))
    if unknown:
        raise SpecError(f"sweep.{unknown[0]}: unknown key (known: {', '.join(_SWEEP_KEYS)})")
    mode = sw.get("mode", "grid")
    if mode not in MODES:
        raise SpecError(f"sweep.mode: expected one of {', '.join(MODES)}, not {mode!r}")
    samples = sw.get("samples")
    if mode != "grid" and (
        isinstance(samples, bool) or not isinstance(samples, int) or samples < 1
    ):
        raise SpecError(f"sweep.samples: mode {mode!r} needs samples >= 1, not {samples!r}")
    seed = sw.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise SpecError(f"sweep.seed: expected an integer >= 0, not {seed!r}")
    retries = sw.get("retries", 2)
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise SpecError(f"sweep.retries: expected an integer >= 0, not {retries!r}")
    rerun = sw.get("rerun_errors", False)
    if not isinstance(rerun, bool):
        raise SpecError(f"sweep.rerun_errors: expected true or false, not {rerun!r}")
    figures = sw.get("figures", ["duration_s"])
    if not isinstance(figures, list) or not figures or not all(isinstance(f, str) for f in figures):
        raise SpecError(f"sweep.figures: expected a list of key-figure names, not {figures!r}")
    from armlab.study.figures import KEY_FIGURES

    unknown = [f for f in figures if f not in KEY_FIGURES]
    if unknown:
        raise SpecError(
            f"sweep.figures: unknown figure {unknown[0]!r} (known: {', '.join(KEY_FIGURES)})"
        )
    name = sw.get("name", Path(source).stem if source != "<dict>" else "sweep")
    if not isinstance(name, str):
        raise SpecError(f"sweep.name: expected a string, not {name!r}")
    params_doc = document.get("parameter", [])
    if not isinstance(params_doc, list) or not params_doc:
        raise SpecError("parameter: at least one [[parameter]] table is needed")
    params = tuple(_parse_parameter(t, f"parameter[{i}]", mode) for i, t in enumerate(params_doc))
    keys = [p.key for p in params]
    if len(set(keys)) != len(keys):
        dup = next(k for k in keys if keys.count(k) > 1)
        raise SpecError(f"parameter: key {dup!r} is varied twice")
    fixed = document.get("set", {})
    if not isinstance(fixed, dict):
        raise SpecError("set: expected a table of dotted study keys")
    fixed = _flatten(fixed)
    clash = sorted(set(fixed) & set(keys))
    if clash:
        raise SpecError(f"set.{clash[0]}: also a varied parameter")
    study = sw.get("study", "demo")
    if not isinstance(study, str):
        raise SpecError(f'sweep.study: expected "demo" or a study file path, not {study!r}')
    study_path = None if study == "demo" else (Path(base_dir) / study)
    try:
        base_doc, study_dir, study_source = read_study_document(study_path)
    except SpecError as exc:
        raise SpecError(f"sweep.study: {exc}") from None
    base_doc = apply_overrides(base_doc, fixed)
    # the base study must be valid by itself (its keys and values); a bad value of a varied key
    # is a row with status "error", not a dead sweep
    from armlab.study.spec import parse_study

    parse_study(base_doc, base_dir=study_dir, source=study_source)
    return SweepSpec(
        name=name,
        mode=mode,
        parameters=params,
        samples=samples,
        seed=seed,
        figures=tuple(figures),
        retries=retries,
        rerun_errors=rerun,
        study_document=base_doc,
        study_dir=study_dir,
        study_source=study_source,
        study_hash=document_hash(base_doc),
        fixed=fixed,
        source=source,
        study_file=(demo_study_path() if study_path is None else study_path).resolve(),
    )


def _flatten(table: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"plan": {"planner": "ptp"}}`` or ``{"plan.planner": "ptp"}`` to dotted keys.

    Tables inside study keys are kept only where a study value is itself a table (none today),
    so a nested TOML table is always a path.
    """
    out = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, f"{key}."))
        else:
            out[key] = v
    return out


def demo_sweep_path() -> Path:
    """The example sweep shipped with armlab (``armlab/data/demo_sweep.toml``)."""
    from importlib import resources

    return Path(str(resources.files("armlab") / "data" / "demo_sweep.toml"))


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and validate a SWEEP.toml (relative paths inside it are relative to its folder);
    ``"demo"`` is the example sweep shipped with armlab."""
    path = demo_sweep_path() if str(path) == "demo" else Path(path)
    document = read_toml(path, "sweep file", SpecError)
    return parse_sweep(document, base_dir=path.resolve().parent, source=str(path))


def parameter_sets(spec: SweepSpec) -> list[dict[str, Any]]:
    """Every parameter set of the sweep, in a reproducible order (``{study key: value}``).

    grid: the Cartesian product (first parameter slowest); random: each parameter drawn
    independently, uniformly, from ``numpy.random.default_rng(seed)``; lhs: a Latin hypercube
    (``scipy.stats.qmc.LatinHypercube(seed=seed)``), one stratum per sample in every dimension.
    Duplicates (possible with value lists) are dropped, keeping the first.
    """
    params = spec.parameters
    if spec.mode == "grid":
        sets = [
            dict(zip(spec.parameter_keys, combo, strict=True))
            for combo in itertools.product(*(p.grid() for p in params))
        ]
    else:
        assert spec.samples is not None  # parse_sweep requires samples for random and lhs
        if spec.mode == "random":
            u = np.random.default_rng(spec.seed).random((spec.samples, len(params)))
        else:
            from scipy.stats import qmc

            u = qmc.LatinHypercube(d=len(params), seed=spec.seed).random(spec.samples)
        sets = [
            {p.key: p.from_unit(float(x)) for p, x in zip(params, row, strict=True)} for row in u
        ]
    seen, out = set(), []
    for s in sets:
        k = parameter_key(s)
        if k not in seen:
            seen.add(k)
            out.append(s)
    return out


def parameter_key(params: dict[str, Any]) -> str:
    """Stable id of a parameter set: sha256 of its canonical JSON, first 16 hex digits.

    Integral floats hash like integers (``300.0`` and ``300`` are the same set).
    """
    canon = {
        k: (int(v) if isinstance(v, float) and v.is_integer() else v)
        for k, v in copy.deepcopy(params).items()
    }
    text = json.dumps(canon, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def definition_sha256(spec: SweepSpec, set_keys: list[str]) -> str:
    """Checksum of what a sweep computes: its base study document, its parameter keys and the
    ids of its parameter sets (``set_keys``, :func:`parameter_key`). Two sweep files with the
    same checksum fill the same rows (the name, figures, mode that draws the same sets, retries
    do not count)."""
    text = json.dumps(
        {
            "study_hash": spec.study_hash,
            "parameters": sorted(spec.parameter_keys),
            "sets": sorted(set_keys),
        },
        separators=(",", ":"),
    )
    return hashlib.sha256(text.encode()).hexdigest()
