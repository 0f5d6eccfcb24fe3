"""python -m simplebot_navigation.viewer [--ros-args -p port:=8765 ...]"""

import sys

from simplebot_navigation.viewer.node import main

sys.exit(main())
