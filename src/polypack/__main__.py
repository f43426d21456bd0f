"""``python -m polypack ...``: the polypack command line."""

from polypack._entry import main

main()
