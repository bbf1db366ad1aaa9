"""`python -m iwr_client`: the `iwr` command line."""

from iwr_client.cli import main

raise SystemExit(main())
