"""``python -m freeflyer``: the same command line as the ``freeflyer`` script."""

from .cli import main

if __name__ == "__main__":
    main()
