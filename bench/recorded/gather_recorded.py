"""Gather the recorded corpus of `bench/recorded/recorded_corpus.yaml` into a folder, from git clones of its
source repositories that you made yourself (this script downloads nothing).

Each file is read at the commit the manifest names (``git show COMMIT:PATH``, so any clone that
holds that commit will do) and written only when its sha256 is the manifest's. Print the clones
needed with ``--clone-commands``; then gather and run the benchmark:

    .venv/bin/python bench/recorded/gather_recorded.py --clone-commands --repos ~/corpus-repos
    .venv/bin/python bench/recorded/gather_recorded.py --repos ~/corpus-repos --out ~/corpus/recorded
    MUJOCO_GL=egl .venv/bin/python bench/recorded/real_recorded.py --files ~/corpus/recorded --worlds ideal mujoco

A clone is looked for at ``REPOS/<owner>__<name>`` (or ``REPOS/<owner>+<name>``, as a plain or a
bare repository). Files already in place with the right sha256 are left alone.
"""

from __future__ import annotations

import argparse
import hashlib
import subprocess
import sys
from pathlib import Path

import yaml

MANIFEST = Path(__file__).with_name("recorded_corpus.yaml")


def _clone_of(repos: Path, source: str) -> Path | None:
    owner, name = source.split("/", 1)
    for folder in (f"{owner}__{name}", f"{owner}+{name}"):
        for candidate in (repos / folder, repos / folder / "repo"):
            if (candidate / ".git").exists() or (candidate / "HEAD").exists():
                return candidate
    return None


def _blob(clone: Path, commit: str, path: str) -> bytes | None:
    git_dir = clone / ".git" if (clone / ".git").exists() else clone
    done = subprocess.run(["git", "--git-dir", str(git_dir), "show", f"{commit}:{path}"], capture_output=True)
    return done.stdout if done.returncode == 0 else None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--manifest", type=Path, default=MANIFEST,
                        help=f"the corpus to gather (default {MANIFEST.name}; bench/recorded/heldout_corpus.yaml is the held-out one)")
    parser.add_argument("--split", default=None, help="only the files of this split (heldout_corpus.yaml: development, held_out)")
    parser.add_argument("--repos", type=Path, required=True, help="folder of the source repositories' clones")
    parser.add_argument("--out", type=Path, help="folder to gather the corpus into")
    parser.add_argument("--clone-commands", action="store_true", help="print the git clone commands needed, and stop")
    args = parser.parse_args()
    files = [f for f in yaml.safe_load(args.manifest.read_text())["files"] if args.split in (None, f.get("split"))]
    if not files:
        parser.error(f"--split: no file of split {args.split!r} in {args.manifest}")
    sources = sorted({f["source_repo"] for f in files})
    if args.clone_commands:
        for source in sources:
            owner, name = source.split("/", 1)
            print(f"git clone https://github.com/{source}.git {args.repos / f'{owner}__{name}'}")
        return 0
    if args.out is None:
        parser.error("--out is required (or --clone-commands)")
    clones = {s: _clone_of(args.repos, s) for s in sources}
    missing = [s for s, clone in clones.items() if clone is None]
    if missing:
        print(f"{args.repos}: no clone of {', '.join(missing)}; --clone-commands prints how to make them",
              file=sys.stderr)
        return 2
    written = kept = 0
    failed: list[str] = []
    for f in files:
        target = args.out / f["file"]
        if target.exists() and hashlib.sha256(target.read_bytes()).hexdigest() == f["sha256"]:
            kept += 1
            continue
        data = _blob(clones[f["source_repo"]], f["commit"], f["path_in_repo"])
        if data is None or hashlib.sha256(data).hexdigest() != f["sha256"]:
            failed.append(f"{f['file']} ({f['source_repo']}@{f['commit'][:10]}:{f['path_in_repo']}: "
                          f"{'not in the clone' if data is None else 'sha256 differs'})")
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        partial = target.with_suffix(target.suffix + ".part")
        partial.write_bytes(data)
        partial.replace(target)
        written += 1
    print(f"{written} written, {kept} already in place, {len(failed)} not gathered, in {args.out}")
    for line in failed:
        print(f"  not gathered: {line}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
