# OpenSSL's libcrypto (Debian libssl-dev): SHA-256 of the input image, the only
# identification of the CT a model file keeps.
find_package(OpenSSL REQUIRED)
