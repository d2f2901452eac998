"""Validate, import and export models in DeepRacer's S3 layout, with the console's import error codes.

`racer model validate|import|export` (racer.model_io.cli) are thin wrappers over:
`validate_location` / `validate_model` -> ValidationReport (ValidationProblem(code, path, message, fix)),
`import_model`, `export_model` -> ImportExportResult.
"""

from racer.model_io.codes import CODE_INFO, ProblemCode
from racer.model_io.destinations import ArchiveDestination, FolderDestination, StoreDestination
from racer.model_io.import_export import ImportExportResult, ModelExistsError, export_model, import_model
from racer.model_io.problems import (
    DEFAULT_LIMITS,
    CheckpointSelection,
    ImportPlan,
    SizeLimits,
    ValidationProblem,
    ValidationReport,
)
from racer.model_io.sources import FolderSource, ModelSource, StoreSource, TarSource, open_source
from racer.model_io.validate import validate_location, validate_model

__all__ = [
    "CODE_INFO",
    "DEFAULT_LIMITS",
    "ArchiveDestination",
    "CheckpointSelection",
    "FolderDestination",
    "FolderSource",
    "ImportPlan",
    "ModelExistsError",
    "ModelSource",
    "ProblemCode",
    "SizeLimits",
    "StoreDestination",
    "StoreSource",
    "TarSource",
    "ImportExportResult",
    "ValidationProblem",
    "ValidationReport",
    "export_model",
    "import_model",
    "open_source",
    "validate_location",
    "validate_model",
]
