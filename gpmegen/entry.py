"""The ``gpmegen`` console command. This module imports nothing at its top, and its function
starts inside ``try``, so that Ctrl-C is taken care of from the command's first line: one line
and exit status 130, never a traceback."""


def main() -> int:
    """Run the command line (:func:`gpmegen.cli.main`); its exit status."""
    try:
        from .fileio import signals_held

        # Ctrl-C waits for the imports to end (a fraction of a second): raised inside them, it can
        # leave a library half imported, and NumPy then reports a broken installation.
        with signals_held():
            from .cli import main as cli_main
            from .cli import quick_exit
        return quick_exit(cli_main())
    except KeyboardInterrupt:
        import sys

        print("gpmegen: interrupted", file=sys.stderr)
        return 130
