"""Command-line options that several racer commands take, each defined once."""
