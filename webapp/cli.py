"""The `tagwall` command line."""

import click


@click.group()
def main() -> None:
    """tagwall: one interactive screen from a wall of monitors."""
