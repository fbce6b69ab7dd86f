# SPDX-License-Identifier: MIT
"""Reproduce the experiments of Popov et al. 2009 ("Object Partitioning Considered Harmful") with spacebvh:
`python -m spacebvh.reproduce` (console script `spacebvh-reproduce`). See cli.py for the options."""


def main(argv=None) -> int:
    from .cli import main as run

    return run(argv)


__all__ = ["main"]
