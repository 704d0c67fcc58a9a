"""``python -m rotor_avc`` is the ``rotor-avc`` command."""
import sys

from .cli import main

sys.exit(main())
