"""``python -m linsense`` runs the CLI."""

from linsense.cli import main

main()
