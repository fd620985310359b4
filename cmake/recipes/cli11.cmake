# CLI11 (Debian libcli11-dev): the command line of `organsim`.
find_package(CLI11 REQUIRED)
