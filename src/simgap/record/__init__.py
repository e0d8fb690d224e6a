"""A run as it is kept: `RunRecord` (history, evaluation, settings, format version), written and
read by `simgap.record.run_files` only, older run directories and store rows through `migrate`."""

from simgap.record.run_files import (
                                     DrivenScenarioFile,
                                     RunFiles,
                                     check_run,
                                     migrate,
                                     migrate_row,
                                     read_run,
                                     rewrite_record,
                                     write_run,
)
from simgap.record.run_record import FORMAT_VERSION, AgentRecord, PlannerRecord, RunRecord, RunSettings

__all__ = ["FORMAT_VERSION", "AgentRecord", "DrivenScenarioFile", "PlannerRecord", "RunFiles", "RunRecord", "RunSettings",
           "check_run", "migrate", "migrate_row", "read_run", "rewrite_record", "write_run"]
