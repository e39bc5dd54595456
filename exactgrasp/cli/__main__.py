"""``python -m exactgrasp.cli``: the ``exactgrasp`` command.

May import: `exactgrasp.cli.main`.
"""

import sys

from exactgrasp.cli.main import main

sys.exit(main())
