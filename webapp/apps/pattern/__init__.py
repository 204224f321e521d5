"""The setup test pattern (``app``), with its page, panel and panel script."""
