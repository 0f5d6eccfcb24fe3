"""The results file of a campaign: JSON lines, the spec first, then one record per finished attempt.

Every record is written, flushed and fsynced the moment its run ends, so killing the campaign (or
the machine) loses at most the runs still going. A run is finished once it has a result, or once
it failed to produce one twice (a crash or a hang is retried once).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

from simplebot_navigation.scenarios.campaign.execution import CampaignError
from simplebot_navigation.scenarios.campaign.spec import CampaignSpec, Run, world_family
from simplebot_navigation.scenarios.report import finite

FORMAT = "simplebot-campaign/1"
MAX_ATTEMPTS = 2


def read_results(path: str) -> tuple[dict, list[dict]]:
    """The header and the run records; a last line cut short by a kill is dropped (its run is redone)."""
    try:
        with open(path, encoding="utf-8") as handle:
            lines = handle.read().split("\n")
    except OSError as err:
        raise CampaignError(f"{path}: {err.strerror}") from err
    records = []
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError as err:
            if number == len(lines):  # the unterminated last line of a killed writer
                break
            raise CampaignError(f"{path}:{number}: not a JSON line: {err}") from err
    if not records or records[0].get("format") != FORMAT:
        raise CampaignError(f"{path}: not a campaign results file (its first line is not a {FORMAT} header)")
    return records[0], records[1:]


def latest_by_run(records: list[dict]) -> dict[str, dict]:
    """The record that counts for each run: its result if it has one, else its last error."""
    latest: dict[str, dict] = {}
    for record in records:
        key = Run.from_dict(record).key
        if key not in latest or latest[key]["error"] or not record["error"]:
            latest[key] = record
    return latest


@dataclass
class ResultsFile:
    """Appends records durably; knows which runs are finished and how many attempts each one had."""

    path: str
    spec: CampaignSpec
    resume: bool = False
    attempts: dict[str, int] = field(default_factory=dict)
    finished: set[str] = field(default_factory=set)

    def __post_init__(self):
        exists = os.path.exists(self.path) and os.path.getsize(self.path) > 0
        if exists and not self.resume:
            raise CampaignError(f"--out {self.path} exists; --resume to finish that campaign, or another --out")
        if exists:
            header, records = read_results(self.path)
            if header["spec"] != self.spec.to_dict():
                raise CampaignError(f"--resume: {self.path} holds another campaign (its spec: {header['spec']})")
            self._truncate_cut_line()
            for record in records:
                self._count(record)
        try:
            self.handle = open(self.path, "a", encoding="utf-8")
        except OSError as err:
            raise CampaignError(f"--out {self.path}: cannot write there: {err.strerror}") from err
        if not exists:
            self._write({"format": FORMAT, "spec": self.spec.to_dict()})

    def _truncate_cut_line(self) -> None:
        """A killed writer can leave a partial last line: cut it (read_results dropped it, so its run is done again)
        so that appends start on a line of their own. A last record that is whole but lost only its newline is
        kept (read_results counted it) and gets the newline."""
        with open(self.path, "rb+") as handle:
            data = handle.read()
            if not data or data.endswith(b"\n"):
                return
            start = data.rfind(b"\n") + 1
            try:
                json.loads(data[start:])
            except ValueError:
                handle.truncate(start)
            else:
                handle.write(b"\n")

    def _count(self, record: dict) -> None:
        key = Run.from_dict(record).key
        self.attempts[key] = self.attempts.get(key, 0) + 1
        if not record["error"] or self.attempts[key] >= MAX_ATTEMPTS:
            self.finished.add(key)

    def _write(self, record: dict) -> None:
        self.handle.write(json.dumps(finite(record), allow_nan=False) + "\n")
        self.handle.flush()
        os.fsync(self.handle.fileno())

    def record(self, run: Run, outcome: dict) -> dict:
        """Append a finished attempt: the run, its outcome (result or error), and the attempt number."""
        record = {**outcome, **run.to_dict(), "family": world_family(run.world),
                  "attempt": self.attempts.get(run.key, 0) + 1}  # the run's own goal item, not the result's label
        if record["error"]:
            record.update(success=False, status="ERROR", failures=[record["error"]])
        self._write(record)
        self._count(record)
        return record

    def retry(self, run: Run) -> bool:
        return run.key not in self.finished

    def close(self) -> None:
        self.handle.close()
