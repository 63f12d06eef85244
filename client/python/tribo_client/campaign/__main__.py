# python3 -m tribo_client.campaign SPEC ... (the same as tribo-campaign). The
# guard matters: Dask's worker processes are spawned and import __main__.
import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
