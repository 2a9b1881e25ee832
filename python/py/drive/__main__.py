"""`python -m drive ...`: the same as the `drive` console command."""

from ._cli import main

main()
