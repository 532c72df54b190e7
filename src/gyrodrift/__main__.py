"""``python -m gyrodrift``: the command line."""

from gyrodrift.cli import main

raise SystemExit(main())
