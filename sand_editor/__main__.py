from sand_editor.cli import main

raise SystemExit(main())
