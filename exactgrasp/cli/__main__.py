"""``python -m exactgrasp.cli``: the ``exactgrasp`` command."""

import sys

from exactgrasp.cli.main import main

sys.exit(main())
