// Compiles the tests' precompiled header once (tests/CMakeLists.txt); no code of its own.
