# CMake generated Testfile for 
# Source directory: /work/main/plugins/algorithms
# Build directory: /work/main/build/plugins/algorithms
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
