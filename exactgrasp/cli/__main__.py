import sys

from exactgrasp.cli.main import main

sys.exit(main())
