# {fmt} (Debian libfmt-dev): formatting of messages and reports.
find_package(fmt REQUIRED)
