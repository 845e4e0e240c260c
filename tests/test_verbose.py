"""`fem-bounce run --verbose` (issue 24, item 6): the libraries' INFO lines and warnings (the form compiler's
gcc lines, ffcx's unclosed C files on a cold cache) reach the terminal only when asked; run.log has them
either way (tests/test_cli.py covers the quiet terminal of a real run)."""
import logging

import pytest

from fem_bounce import cli, library_log


@pytest.mark.parametrize("verbose", [False, True])
def test_library_lines_reach_the_terminal_only_with_verbose(verbose, capsys, monkeypatch):
    monkeypatch.setattr(library_log.LIBRARY_LOG, "verbose", verbose)
    root = logging.getLogger()
    level = root.level
    root.setLevel(logging.INFO)  # as cffi's distutils leaves it while compiling a form
    try:
        with library_log.library_output():
            logging.getLogger("distutils-like").info("x86_64-linux-gnu-gcc -shared libffcx_forms_0.o")
            cli._show_warning(ResourceWarning("unclosed file <libffcx_forms_0.c>"), ResourceWarning,
                              "/usr/lib/python3/dist-packages/ffcx/codegeneration/jit.py", 65)
            kept = list(library_log.LIBRARY_LOG.lines)
    finally:
        root.setLevel(level)
        library_log.LIBRARY_LOG.lines.clear()
    err = capsys.readouterr().err
    assert any("gcc" in line for line in kept) and any("unclosed file" in line for line in kept)
    assert ("gcc" in err and "unclosed file" in err) == verbose
    assert ("gcc" in err or "unclosed file" in err) == verbose


def test_run_takes_verbose():
    args = cli._parser().parse_args(["run", "--verbose"])
    assert args.verbose and not cli._parser().parse_args(["run"]).verbose
