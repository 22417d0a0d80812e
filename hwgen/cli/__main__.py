"""`python -m hwgen.cli`: the program."""
from . import main

main()
