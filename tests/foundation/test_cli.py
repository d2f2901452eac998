import subprocess
import sys
from pathlib import Path

from racer.cli import COMMANDS


def test_help_lists_every_subcommand_with_one_line():
    """The installed `racer` script (what the README runs), its Commands section: every subcommand, each with a
    summary."""
    racer = Path(sys.executable).with_name("racer")
    result = subprocess.run([str(racer), "--help"], capture_output=True, text=True, check=True)
    listed: dict[str, str] = {}
    lines = result.stdout.splitlines()
    for line in lines[lines.index("Commands:") + 1 :]:
        if line.startswith("  ") and not line.startswith("   "):  # "  name  summary"; deeper lines continue it
            name, _, summary = line.strip().partition(" ")
            listed[name] = summary.strip()
    assert set(listed) == set(COMMANDS)
    assert all(len(summary) > 10 for summary in listed.values()), listed


def test_every_subcommand_imports():
    import importlib

    for name, (target, _) in COMMANDS.items():
        module_name, attribute = target.split(":")
        command = getattr(importlib.import_module(module_name), attribute)
        assert command.name or name
