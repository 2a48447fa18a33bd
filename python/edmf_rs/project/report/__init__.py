"""The HTML report of a project run (``html``) and its figures (``plots``)."""
