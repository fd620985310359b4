# nlohmann-json (Debian nlohmann-json3-dev): the commands' --json output.
find_package(nlohmann_json 3.10 REQUIRED)
