"""Project plumbing every other part of cosim uses: where the project folder and its build
outputs are (paths), the processes a run starts (procs), the tools and their versions
(toolchain, doctor), the progress bar of long runs (progress) and the argument-parsing rules
every `bowden` subcommand follows (cliargs)."""
