from box2d_driving.cli import main

raise SystemExit(main())
