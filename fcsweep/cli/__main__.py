"""``python -m fcsweep.cli``: the ``fcsweep`` command."""

from fcsweep.cli.main import main

if __name__ == "__main__":
    main()
