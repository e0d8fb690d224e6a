"""The results store of an experiment: one row per finished run, queryable with DuckDB.

Layout of an experiment directory::

    experiment.json            the spec, its results hash, the software versions
    scenarios/                 the generated CommonRoad scenarios (XML + metadata)
    runs/SCENARIO/FIDELITY/    each run's own directory (run.json, trajectories.parquet, driven.xml)
    store/rows/KEY.parquet     one row per finished run (ok or failed), written atomically
    store/results.parquet      all rows in one file, rebuilt from the rows
    report/                    the HTML report
    .writer.lock               locked by the one `simgap experiment run` writing here (`simgap.files.sole_writer`)

A row is written (to a temporary file, then renamed) only after its run directory is complete,
so a row always describes a whole run; a run killed half-way leaves no row and is run again on
resume, and so is a run whose worker died under it or that the machine failed (a full disk, no
memory: its row says so until then), a row file that cannot be read and a row whose run directory
is gone or damaged. Nothing else in the directory is read as a result.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from simgap.errors import InputError
from simgap.experiment.run_row import RunRow
from simgap.files import atomic_write, remove_stale_temporaries
from simgap.record import check_run, migrate_row

WORKER_DIED = "worker died"     # the failure of a run whose worker died under it (a crash, a kill, a lost node)
MACHINE_FAILED = "the machine failed"   # ... of a run the machine failed (a full disk, no memory): not its input's
NOT_A_RESULT = (WORKER_DIED, MACHINE_FAILED)    # failures that say nothing of the run: it runs again on resume


def row_file_name(key: str) -> str:
    """A file name for a job key (readable, and unique through a short hash)."""
    safe = "".join(c if c.isalnum() or c in "-_." else "~" for c in key)
    return f"{safe[:150]}__{hashlib.sha1(key.encode()).hexdigest()[:8]}.parquet"


class ResultsStore:
    def __init__(self, root: Path):
        self.root = Path(root)
        self.rows_dir = self.root / "store" / "rows"
        self.unusable_rows: dict[Path, str] = {}     # row file -> why it was left out, as the last read found

    def prepare(self) -> None:
        """Make the store's folder and remove what writers killed mid-write left anywhere under
        the output folder (rows, budget, meta files); the driver calls it before any writer starts."""
        self.rows_dir.mkdir(parents=True, exist_ok=True)
        remove_stale_temporaries(self.root)

    def write_row(self, row: RunRow) -> Path:
        """Write ``row`` (atomically) with the schema its type gives."""
        return self._write(pa.Table.from_pylist([row.columns()], schema=row.schema()))

    def _write(self, table: pa.Table) -> Path:
        key = table.column("key")[0].as_py()
        return atomic_write(self.rows_dir / row_file_name(key), lambda tmp: pq.write_table(table, tmp))

    def row_files(self) -> list[Path]:
        return sorted(p for p in self.rows_dir.glob("*.parquet") if not p.name.startswith("."))

    def _usable_rows(self) -> dict[Path, list[dict[str, Any]]]:
        """The rows of every row file that stands for a run, by file. A file that cannot be read
        (cut short by a full disk or a crash of the machine) and a row whose run directory is gone
        or damaged (a ``run.json`` or trajectories that `read_run` would refuse) stand for nothing: they are left out and named in ``unusable_rows``, so their jobs count as
        not run and run again on resume (whose new row replaces the file)."""
        self.unusable_rows = {}
        usable = {}
        for path in self.row_files():
            try:
                rows = [migrate_row(r) for r in pq.read_table(path).to_pylist()]
            except (pa.ArrowException, OSError) as exc:
                self.unusable_rows[path] = f"cannot be read ({str(exc).splitlines()[0]})"
                continue
            damage = next((why for why in map(self._run_damage, rows) if why), None)
            if damage is not None:
                self.unusable_rows[path] = damage
                continue
            usable[path] = rows
        return usable

    def _run_damage(self, row: dict[str, Any]) -> str | None:
        """Why the run directory of ``row`` stands for no run (gone, or damaged: `check_run`), or None."""
        if not row.get("run_dir"):
            return None
        run_dir = self.root / row["run_dir"]
        if not (run_dir / "run.json").is_file():
            return f"its run directory {row['run_dir']} is gone"
        try:
            check_run(run_dir)
        except InputError as err:
            where = Path(err.file or "").name + (f" field '{err.field}'" if err.field else "")
            return f"its run directory {row['run_dir']} is damaged ({where}: {err.reason})"
        return None

    def rows(self) -> list[dict[str, Any]]:
        """Every row that stands for a run, as stored: column -> value (for queries and tools;
        `run_rows` types them)."""
        return [row for rows in self._usable_rows().values() for row in rows]

    def run_rows(self) -> list[RunRow]:
        """Every row, typed (`RunRow.from_columns`)."""
        return [RunRow.from_columns(r) for r in self.rows()]

    def finished_rows(self) -> list[dict[str, Any]]:
        """The rows of the finished runs. A run whose worker died under it, or that the machine
        failed, is not finished: it has no result of its own, and runs again on resume."""
        return [r for r in self.rows() if not str(r.get("failure") or "").startswith(NOT_A_RESULT)]

    def finished_keys(self) -> dict[str, str]:
        """Job key -> status ('ok' or 'failed') of every finished run."""
        return {r["key"]: r["status"] for r in self.finished_rows()}

    def consolidate(self) -> Path | None:
        """Write ``store/results.parquet`` with every row (columns: the union over rows)."""
        rows = self.rows()
        if not rows:
            return None
        columns = list(dict.fromkeys(k for r in rows for k in r))
        table = pa.Table.from_pylist([{c: r.get(c) for c in columns} for r in rows])
        return atomic_write(self.root / "store" / "results.parquet", lambda tmp: pq.write_table(table, tmp))

    def connect(self):
        """An in-memory DuckDB connection with the table ``runs`` (one row per run that `rows` reads),
        closed to files and extensions: a query changes nothing in the store or elsewhere."""
        import duckdb

        files = list(self._usable_rows())
        if not files:
            raise InputError("no finished runs in this experiment yet", file=self.root)
        con = duckdb.connect()
        con.execute("CREATE TABLE runs AS SELECT * FROM read_parquet(?, union_by_name=true)", [[str(p) for p in files]])
        con.execute("SET enable_external_access = false")     # a query reads and writes no file, loads nothing
        con.execute("SET lock_configuration = true")
        return con

    def query(self, sql: str) -> tuple[list[str], list[tuple]]:
        import duckdb

        con = self.connect()
        try:
            cursor = con.execute(sql)
        except duckdb.Error as exc:
            raise InputError(f"query failed: {str(exc).splitlines()[0]}", field="SQL",
                             allowed="DuckDB SQL over the table 'runs'") from None
        columns = [d[0] for d in cursor.description] if cursor.description else []
        return columns, cursor.fetchall()
