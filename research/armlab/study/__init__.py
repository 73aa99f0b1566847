"""Studies: one TOML file describes a whole study; :func:`run_study` runs the chain into a folder.

The chain (DESIGN.md): robot -> kinematics checks -> plan -> static load -> drive sizing ->
servo tuning -> closed-loop tracking -> export. ``armlab run [STUDY.toml] --out DIR`` calls
:func:`run_study`; sweeps and notebooks use :func:`load_study` and :func:`run_spec`.
"""

from armlab.study.export import EXPORT_FORMATS, ExportResult, export_study
from armlab.study.runner import (
    KEY_FIGURES,
    StudyResult,
    key_figures,
    run_spec,
    run_study,
    write_json,
)
from armlab.study.spec import (
    PLANNERS,
    STAGES,
    StudySpec,
    apply_overrides,
    check_key,
    demo_study_path,
    load_study,
    parse_study,
    read_study_document,
)

__all__ = [
    "EXPORT_FORMATS",
    "ExportResult",
    "export_study",
    "KEY_FIGURES",
    "PLANNERS",
    "STAGES",
    "StudySpec",
    "StudyResult",
    "apply_overrides",
    "check_key",
    "demo_study_path",
    "key_figures",
    "load_study",
    "parse_study",
    "read_study_document",
    "run_spec",
    "run_study",
    "write_json",
]
