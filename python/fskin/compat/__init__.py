"""Drop-in replacements for code written against other projects' APIs."""
