import sys

from nvrq.cli import main

sys.exit(main())
