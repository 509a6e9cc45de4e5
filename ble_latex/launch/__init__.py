"""Launch planning: where and when to launch (issue 46, docs/launch.md)."""
