import sys

from omnislam.cli import main

sys.exit(main())
