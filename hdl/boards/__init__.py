"""The boards' top modules and pin files."""
