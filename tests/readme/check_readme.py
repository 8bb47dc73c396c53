#!/usr/bin/env python3
"""Runs README.md's examples as written (issue 46): every command of its
```sh blocks, in order, as a new user pastes them after scripts/build.sh.

Usage: check_readme.py [PRT_EXE [SOURCE_DIR]] [--list]

PRT_EXE (default $PRT_EXE) stands in for `build/prt`; SOURCE_DIR (default
the tree this script is in) holds README.md, models/, envmaps/ and
scripts/. The commands run with bash in a temporary directory holding
symlinks to those three folders, so every file a command names must be
shipped there or made by an earlier command, and the outputs land in the
temporary directory. A command continued with a trailing backslash is one
command. Left out: the install scripts (scripts/demo.sh, scripts/test.sh),
`prt view` (it needs a display) and `python3 -m http.server` (a server that
never exits; of `A && python3 -m http.server ...` only A runs). A command
starting with mpirun runs only when mpirun is on PATH (otherwise it is
skipped and the output says so), as root with Open MPI's
OMPI_ALLOW_RUN_AS_ROOT{,_CONFIRM}=1.

Exit 0 when every command exits 0; 1 otherwise, with one block per failed
command: its README line, exit status and the tail of its stderr. --list
prints the commands and runs none.
"""
import os
import pathlib
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

COMMAND_TIMEOUT_S = 600  # the slowest example (prt reference, prt compress) takes about a minute on 2 cores
TAIL_LINES = 20
SKIPPED_PREFIXES = ("scripts/demo.sh", "scripts/test.sh", "build/prt view")
SERVER_PREFIX = "python3 -m http.server"
LINKED_FOLDERS = ("models", "envmaps", "scripts")
PRT_TOKEN = re.compile(r"(?<![\w./-])build/prt(?![\w./-])")


def sh_commands(readme):
    """(line number, command) of every command in README's ```sh blocks, continuations joined."""
    commands, in_block, pending, start = [], False, "", 0
    for number, line in enumerate(readme.read_text(encoding="utf-8").splitlines(), 1):
        stripped = line.strip()
        if stripped.startswith("```"):
            in_block = stripped == "```sh"
            continue
        if not in_block:
            continue
        if not pending:
            start = number
        if line.rstrip().endswith("\\"):
            pending += line.rstrip()[:-1] + " "
            continue
        command = (pending + line).strip()
        pending = ""
        if command and not command.startswith("#"):
            commands.append((start, command))
    return commands


def runnable(command):
    """The part of a command to run, or None to leave it out (install scripts, prt view, servers)."""
    if command.startswith(SKIPPED_PREFIXES):
        return None
    kept = [part.strip() for part in command.split("&&") if not part.strip().startswith(SERVER_PREFIX)]
    return " && ".join(kept) if kept else None


def tail(text, lines=TAIL_LINES):
    return "\n".join("    " + line for line in text.rstrip().splitlines()[-lines:])


def run_all(commands, prt, source, environment):
    """Runs the commands in one temporary directory; returns the failure reports and the skipped count."""
    failures, skipped = [], 0
    with tempfile.TemporaryDirectory(prefix="prt-readme-") as work:
        for folder in LINKED_FOLDERS:
            os.symlink(source / folder, os.path.join(work, folder))
        for number, command in commands:
            if command.startswith("mpirun") and shutil.which("mpirun") is None:
                print(f"README.md:{number}: skipped (mpirun is not on PATH): {command}", flush=True)
                skipped += 1
                continue
            line = PRT_TOKEN.sub(lambda _: shlex.quote(str(prt)), command)
            started = time.monotonic()
            try:
                r = subprocess.run(["bash", "-c", line], cwd=work, env=environment, capture_output=True,
                                   text=True, errors="replace", timeout=COMMAND_TIMEOUT_S)
                status, err, out = r.returncode, r.stderr, r.stdout
            except subprocess.TimeoutExpired as e:
                status, err, out = f"timed out after {COMMAND_TIMEOUT_S} s", e.stderr or "", e.stdout or ""
                err, out = [s.decode(errors="replace") if isinstance(s, bytes) else s for s in (err, out)]
            seconds = time.monotonic() - started
            print(f"README.md:{number}: exit {status}, {seconds:.1f} s: {command}", flush=True)
            if status != 0:
                shown = ("stderr", err) if err.strip() else ("stdout", out)
                failures.append(f"README.md:{number}: exit {status}: {command}\n  {shown[0]} (last {TAIL_LINES} "
                                f"lines):\n{tail(shown[1])}")
    return failures, skipped


def main(argv):
    listing = "--list" in argv
    args = [a for a in argv if a != "--list"]
    prt = args[0] if args else os.environ.get("PRT_EXE")
    source = pathlib.Path(args[1] if len(args) > 1 else pathlib.Path(__file__).resolve().parents[2]).resolve()
    commands = [(n, c) for n, c in ((n, runnable(c)) for n, c in sh_commands(source / "README.md")) if c]
    if not commands or not any(PRT_TOKEN.search(c) for _, c in commands):
        print(f"check_readme: no build/prt command found in {source / 'README.md'}'s ```sh blocks")
        return 1
    if listing:
        for number, command in commands:
            print(f"README.md:{number}: {command}")
        return 0
    if not prt or not os.access(prt, os.X_OK):
        print(f"check_readme: the prt to test ({prt!r}; argument 1 or $PRT_EXE) is not an executable")
        return 1
    environment = dict(os.environ)
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # Open MPI refuses root without these
        environment.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    started = time.monotonic()
    failures, skipped = run_all(commands, pathlib.Path(prt).resolve(), source, environment)
    print(f"{len(commands) - skipped} README commands run ({skipped} skipped), {len(failures)} failed, "
          f"{time.monotonic() - started:.1f} s")
    for failure in failures:
        print(failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
