"""The boards' top modules, pin files and the table of their facts (`hdl.boards.table`)."""
