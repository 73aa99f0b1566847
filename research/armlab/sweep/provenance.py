"""What a sweep row was computed from: armlab's version and the sha256 of every input file.

A study reads, besides its document: the robot's URDF (``robot.name``), the ``drives.toml`` and
``mdh.toml`` beside it, the drive catalogue (``sizing.catalogue`` or the one shipped with armlab)
and the controller profile (``controller.profile`` or the reference one). :func:`row_provenance`
finds and hashes them for one parameter set and folds them -- with armlab's version, the sha256
of the base study document and the parameter set -- into ``inputs_sha256``. A finished row is
reused on a resume only while its ``inputs_sha256`` is the one its parameter set gives now; the
worker computes the same columns from the files it reads, so a row always records what it was
really computed from.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from armlab.errors import ArmlabError

__all__ = [
    "PROVENANCE_FIELDS",
    "FILE_INPUTS",
    "input_files",
    "file_hashes",
    "row_provenance",
    "describe_changes",
]

#: The input files of a study: column prefix -> name in messages.
FILE_INPUTS = {
    "urdf": "URDF",
    "drives": "drives.toml",
    "mdh": "mdh.toml",
    "catalogue": "drive catalogue",
    "profile": "controller profile",
}

#: Provenance columns of every result row.
PROVENANCE_FIELDS = (
    "armlab_version",
    "study_sha256",
    *(f"{name}_sha256" for name in FILE_INPUTS),
    "inputs_sha256",
)

_WHAT = {
    "armlab_version": "armlab version",
    "study_sha256": "base study",
    **{f"{name}_sha256": label for name, label in FILE_INPUTS.items()},
}


def _resolve(base_dir: Path, name: str) -> str:
    """A path relative to the study file made absolute; a bare name stays as it is (the rule
    of :meth:`armlab.study.spec.StudySpec.resolve`)."""
    p = Path(name)
    if p.is_absolute() or ("/" not in name and "\\" not in name and not p.suffix):
        return name
    return str((base_dir / p).resolve())


def _named(document: dict[str, Any], table: str, key: str) -> str | None:
    t = document.get(table)
    v = t.get(key) if isinstance(t, dict) else None
    return v if isinstance(v, str) else None


def input_files(document: dict[str, Any], study_dir: str | Path) -> dict[str, Path | None]:
    """The files a study document reads (:data:`FILE_INPUTS` keys; None: none, or it cannot be
    found -- the study then fails with its own message)."""
    from armlab.robot.catalogue import default_catalogue_path
    from armlab.robot.controller import DEFAULT_PROFILE, _profile_path
    from armlab.robot.model import _find_urdf

    base = Path(study_dir)
    out: dict[str, Path | None] = dict.fromkeys(FILE_INPUTS)
    robot = _named(document, "robot", "name")
    if robot is not None:
        urdf: Path | None = None
        folder: Path | None = None
        try:
            _, urdf, folder = _find_urdf(_resolve(base, robot))
        except (ArmlabError, OSError):
            pass
        out["urdf"] = urdf
        if folder is not None:
            for name in ("drives", "mdh"):
                f = folder / f"{name}.toml"
                out[name] = f if f.is_file() else None
    catalogue = _named(document, "sizing", "catalogue")
    out["catalogue"] = (
        default_catalogue_path() if catalogue is None else Path(_resolve(base, catalogue))
    )
    profile = _named(document, "controller", "profile")
    try:
        out["profile"] = _profile_path(
            DEFAULT_PROFILE if profile is None else _resolve(base, profile)
        )
    except ArmlabError:
        out["profile"] = None
    return out


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def file_hashes(
    files: dict[str, Path | None], memo: dict[Path, str] | None = None
) -> dict[str, str]:
    """``{"<name>_sha256": hex}`` of :func:`input_files`; "" for a file that is not there.

    ``memo`` caches the hashes within one call site (one sweep run), never across runs.
    """
    out = {}
    for name, path in files.items():
        digest = ""
        if path is not None:
            if memo is not None and path in memo:
                digest = memo[path]
            else:
                try:
                    digest = _sha256(path)
                except OSError:
                    digest = ""
                if memo is not None:
                    memo[path] = digest
        out[f"{name}_sha256"] = digest
    return out


def row_provenance(
    document: dict[str, Any],
    study_dir: str | Path,
    params: dict[str, Any],
    key: str,
    memo: dict[Path, str] | None = None,
) -> dict[str, str]:
    """The provenance columns (:data:`PROVENANCE_FIELDS`) of one parameter set.

    Parameters
    ----------
    document : dict
        The base study document (``[set]`` applied, the parameters not yet).
    study_dir : path
        The folder its relative paths refer to.
    params : dict
        The parameter set (dotted study keys).
    key : str
        Its id (:func:`armlab.sweep.spec.parameter_key`).
    memo : dict, optional
        File-hash cache of one sweep run (:func:`file_hashes`).
    """
    from armlab.deploy.provenance import armlab_version
    from armlab.study.spec import apply_overrides, document_hash

    try:
        doc = apply_overrides(document, params)
    except ArmlabError:  # a bad key: the row is an error; its files are the base study's
        doc = document
    out = {
        "armlab_version": str(armlab_version()),
        "study_sha256": document_hash(document),
        **file_hashes(input_files(doc, study_dir), memo),
    }
    text = json.dumps({**out, "key": key}, sort_keys=True, separators=(",", ":"))
    out["inputs_sha256"] = hashlib.sha256(text.encode()).hexdigest()
    return out


def describe_changes(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """What differs between two provenance records, in words (``"drives.toml"``, ``"armlab
    version 0.1.0 -> 0.2.0"``); a record without provenance is ``"no provenance recorded"``."""
    if not isinstance(old.get("inputs_sha256"), str) or not old.get("inputs_sha256"):
        return ["no provenance recorded (an older armlab)"]
    out = []
    for field, what in _WHAT.items():
        a, b = old.get(field), new.get(field)
        if a == b:
            continue
        if field == "armlab_version":
            out.append(f"{what} {a} -> {b}")
        else:
            out.append(f"{what} (sha256 {str(a)[:8] or 'none'} -> {str(b)[:8] or 'none'})")
    return out or ["parameter set"]
