from modesel.cli import main

raise SystemExit(main())
