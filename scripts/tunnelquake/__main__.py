import sys

from .cli import main

if __name__ == "__main__":  # not when a pool's worker imports the parent's main module (mpi4py.futures)
    sys.exit(main())
