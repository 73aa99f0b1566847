"""The drive catalogue: motors and reducers that :func:`select_drives` combines.

A TOML file (default: ``armlab/data/catalogue.toml``) with ``[[motor]]`` and ``[[reducer]]`` entries
(and ``[[amplifier]]`` servo amplifiers, :class:`armlab.robot.drives.Amplifier`, named by drives
files and studies) whose fields are those of :class:`armlab.robot.Motor` /
:class:`armlab.robot.Reducer` (``mass_kg`` and ``price`` required), plus ``derating`` on a motor
(extra factor on its torque limits, default 1) and ``thesis_joints`` (joints of teachbot6 that use
the part in thesis table 4.3). Every entry's ``source`` names the document, table or page each value
was read from; ``estimated`` lists the fields that were not read from a published source (the file's
header states the rules). Selection combines only usable pairs (:meth:`Catalogue.combinations`): no
estimated physical field unless the study opts in (``[sizing] allow_estimated = true``), and the two
halves of an integrated smart servo (``integrated``) only with each other.

The shipped catalogue (``docs/catalogue.md``, generated from it) spans integrated smart servos
(Dynamixel XM430/XM540, Feetech STS3215), the thesis' small DC motors and harmonic reducers,
maxon RE / EC flat / EC-i / EC-4pole motors (0.09-1.6 N m continuous, read from maxon's product
pages) with maxon GP planetary gearheads, Beckhoff AG2400 planetary gearboxes up to 794 N m
rated, and Harmonic Drive CSF/CSG, Nabtesco RV-E, Neugart PLE and Kollmorgen AKM entries whose
rating values are still marked estimated. Entries are usable by model name in a drives file
(``motor = "..."``) and in a study's ``[drives.<joint>]`` (:meth:`Catalogue.motor`,
:meth:`Catalogue.reducer`), estimated or not.
"""

from __future__ import annotations

import difflib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

from armlab.errors import RobotDescriptionError
from armlab.robot.drives import Amplifier, Motor, Reducer
from armlab.robot.drives_file import amplifier_from_dict, motor_from_dict, reducer_from_dict
from armlab.tomlfile import read_toml

__all__ = [
    "Catalogue",
    "load_catalogue",
    "default_catalogue_path",
    "MINOR_FIELDS",
    "usable",
]

#: fields whose estimate does not make a part unusable: mass and price only rank candidates,
#: and data sheets give no viscous friction (the small value assumed, about 0.4 % of a motor's
#: nominal torque at its nominal speed, only damps the model)
MINOR_FIELDS = ("mass_kg", "price", "viscous_friction_Nm_s_rad")


def default_catalogue_path() -> Path:
    """``armlab/data/catalogue.toml`` (shipped with the package)."""
    return Path(__file__).resolve().parents[1] / "data" / "catalogue.toml"


@dataclass(frozen=True)
class Catalogue:
    """Motors and reducers with mass [kg] and price (``currency``).

    Attributes
    ----------
    motors, reducers : tuple
    derating : dict of motor model to float
    thesis_parts : dict of joint name to (motor model, reducer model)
        The parts of thesis table 4.3, when the catalogue tags them.
    """

    motors: tuple[Motor, ...]
    reducers: tuple[Reducer, ...]
    derating: dict[str, float] = field(default_factory=dict)
    thesis_parts: dict[str, tuple[str | None, str | None]] = field(default_factory=dict)
    currency: str = ""
    path: str = ""
    amplifiers: tuple[Amplifier, ...] = ()

    def amplifier(self, model: str, where: str = "") -> Amplifier:
        """The servo amplifier ``model`` of the ``[[amplifier]]`` entries (as :meth:`motor`);
        amplifiers are named by drives files and studies, not combined by the selection."""
        for a in self.amplifiers:
            if a.model == model:
                return a
        raise _unknown("amplifier", model, [a.model for a in self.amplifiers], where or self.path)

    def combinations(self, allow_estimated: bool = False) -> list[tuple[Motor, Reducer]]:
        """Every motor x reducer pair selection may combine: both halves usable
        (:func:`usable`) and of the same integrated servo, or both sold alone
        (``integrated == ""``)."""
        return [
            (m, r)
            for m in self.motors
            if usable(m, allow_estimated)
            for r in self.reducers
            if usable(r, allow_estimated) and m.integrated == r.integrated
        ]

    def motor(self, model: str, where: str = "") -> Motor:
        """The motor ``model`` (:class:`RobotDescriptionError` naming ``where``, the key that
        asked, and the nearest names)."""
        for m in self.motors:
            if m.model == model:
                return m
        raise _unknown("motor", model, [m.model for m in self.motors], where or self.path)

    def reducer(self, model: str, where: str = "") -> Reducer:
        """The reducer ``model`` (as :meth:`motor`)."""
        for r in self.reducers:
            if r.model == model:
                return r
        raise _unknown("reducer", model, [r.model for r in self.reducers], where or self.path)


def usable(part: Motor | Reducer, allow_estimated: bool = False) -> bool:
    """True when selection may use ``part``: no estimated field other than
    :data:`MINOR_FIELDS`, or the study allows estimated values."""
    return allow_estimated or not (set(part.estimated) - set(MINOR_FIELDS))


def _unknown(kind: str, model: str, known: list[str], where: str) -> RobotDescriptionError:
    near = difflib.get_close_matches(model, known, n=3, cutoff=0.4)
    hint = f" (closest: {'; '.join(near)})" if near else f" ({len(known)} {kind}s in it)"
    return RobotDescriptionError(f"{where}: no {kind} {model!r} in the catalogue{hint}")


def load_catalogue(path: str | os.PathLike | None = None) -> Catalogue:
    """Read a drive catalogue (default: the one shipped with armlab).

    Raises
    ------
    RobotDescriptionError
        Missing or malformed file, unknown fields, duplicate models, no mass or price,
        non-positive ratio, efficiency outside (0, 1].
    """
    path = default_catalogue_path() if path is None else Path(path)
    data = read_toml(path, "catalogue file")
    derating: dict[str, float] = {}
    thesis: dict[str, list[str | None]] = {}

    def parts(kind: str, build):
        out: list = []
        for k, row in enumerate(data.get(kind, [])):
            row = dict(row)
            where = f"{path} {kind} {k + 1} ({row.get('model', '?')})"
            extra_derating = row.pop("derating", 1.0)
            joints = row.pop("thesis_joints", [])
            part = build(row, where)
            for key in ("mass_kg", "price"):
                v = getattr(part, key)
                if not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                    raise RobotDescriptionError(f"{where}: {key} must be a number >= 0")
            if any(p.model == part.model for p in out):
                raise RobotDescriptionError(f"{where}: duplicate model {part.model!r}")
            if kind == "motor":
                if not 0 < float(extra_derating) <= 1:
                    raise RobotDescriptionError(f"{where}: derating must be in (0, 1]")
                derating[part.model] = float(extra_derating)
            else:
                if part.ratio <= 0 or not 0 < part.efficiency <= 1:
                    raise RobotDescriptionError(
                        f"{where}: ratio must be > 0 and efficiency in (0, 1]"
                    )
            for j in joints:
                slot = thesis.setdefault(str(j), [None, None])
                slot[0 if kind == "motor" else 1] = part.model
            out.append(part)
        if not out:
            raise RobotDescriptionError(f"{path}: no [[{kind}]] entries")
        return tuple(out)

    motors = parts("motor", motor_from_dict)
    reducers = parts("reducer", reducer_from_dict)
    amplifiers: list[Amplifier] = []
    for k, row in enumerate(data.get("amplifier", [])):
        where = f"{path} amplifier {k + 1} ({dict(row).get('model', '?')})"
        amp = amplifier_from_dict(dict(row), where)
        if any(a.model == amp.model for a in amplifiers):
            raise RobotDescriptionError(f"{where}: duplicate model {amp.model!r}")
        amplifiers.append(amp)
    _check_integrated(motors, reducers, path)
    return Catalogue(
        motors=motors,
        reducers=reducers,
        derating=derating,
        thesis_parts={j: (m, r) for j, (m, r) in thesis.items()},
        currency=str(data.get("currency", "")),
        path=str(path),
        amplifiers=tuple(amplifiers),
    )


def _check_integrated(motors, reducers, path) -> None:
    """Each integrated servo has exactly one motor and one reducer entry."""
    for kind, mine, other in (("motor", motors, reducers), ("reducer", reducers, motors)):
        for p in mine:
            n = sum(q.integrated == p.integrated for q in other)
            if p.integrated and n != 1:
                raise RobotDescriptionError(
                    f"{path} {kind} {p.model!r}: integrated {p.integrated!r} needs exactly one "
                    f"{'reducer' if kind == 'motor' else 'motor'} of that servo ({n} found)"
                )
