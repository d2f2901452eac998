import subprocess
import sys

from racer.cli import COMMANDS


def test_help_lists_every_subcommand_with_one_line():
    result = subprocess.run([sys.executable, "-m", "racer.cli", "--help"], capture_output=True, text=True, check=True)
    for name, (_, summary) in COMMANDS.items():
        assert name in result.stdout
        assert summary.split(":")[0][:30] in result.stdout.replace("\n", " ").replace("  ", " ") or name in result.stdout


def test_every_subcommand_imports():
    import importlib

    for name, (target, _) in COMMANDS.items():
        module_name, attribute = target.split(":")
        command = getattr(importlib.import_module(module_name), attribute)
        assert command.name or name
