"""The queries a search answers: one protocol (``base``), one module per query."""
