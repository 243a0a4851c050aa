"""``python -m flexbody.cli``: the ``flexbody`` command."""

import sys

from flexbody.cli import main

sys.exit(main())
