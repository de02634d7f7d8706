"""``haptex explore``: the interactive explorer."""

from __future__ import annotations


import click



@click.command()
@click.option("--port", type=int, default=5006, show_default=True, help="TCP port (0: any free port).")
@click.option("--no-browser", is_flag=True, help="Do not open the page in a browser.")
def explore(port, no_browser):
    """Explore a texture's force field, gain, curl, loop energies and scans in the browser.

    Serves http://127.0.0.1:PORT/ until interrupted (Ctrl-C)."""
    from ..explore import serve

    serve(port, open_browser=not no_browser,
          announce=lambda url: click.echo(f"haptex explore: serving {url} (Ctrl-C to stop)"))
