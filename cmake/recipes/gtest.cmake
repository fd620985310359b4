# GoogleTest (Debian libgtest-dev). GoogleMock is not used.
find_package(GTest REQUIRED)
include(GoogleTest)
