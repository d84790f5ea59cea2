"""``python -m e2esim`` runs the command line."""

from e2esim.cli import main

raise SystemExit(main())
