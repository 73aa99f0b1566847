"""Studies: one TOML file describes a whole study; :func:`run_study` runs the chain into a folder.

The chain (DESIGN.md): robot -> kinematics checks -> plan -> static load -> drive sizing ->
servo tuning -> closed-loop tracking -> export. ``armlab run [STUDY.toml] --out DIR`` calls
:func:`run_study`; sweeps and notebooks use :func:`load_study` and :func:`run_spec`.
"""

from armlab.study.export import ExportResult, export_study
from armlab.study.runner import StudyResult, run_spec, run_study
from armlab.study.spec import StudySpec, apply_overrides, demo_study_path, load_study, parse_study

__all__ = [
    "ExportResult",
    "StudyResult",
    "StudySpec",
    "apply_overrides",
    "demo_study_path",
    "export_study",
    "load_study",
    "parse_study",
    "run_spec",
    "run_study",
]
