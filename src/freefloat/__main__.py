"""``python -m freefloat``: the same command line as the ``freefloat`` script."""

from .cli import main

if __name__ == "__main__":
    main()
