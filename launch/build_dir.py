"""The build folder whose executables the launch scripts run (launch/folders.sh):
$COSIM_BUILD_DIR where it is set and not empty, else ROOT/build. The studies import
build_dir(); run as a script it prints the folder.

  /usr/bin/python3 launch/build_dir.py
"""

import argparse
import os
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def build_dir(root=ROOT) -> Path:
    return Path(os.environ.get("COSIM_BUILD_DIR") or Path(root) / "build").resolve()


if __name__ == "__main__":
    argparse.ArgumentParser(description=__doc__.split("\n")[0], epilog=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    print(build_dir())
