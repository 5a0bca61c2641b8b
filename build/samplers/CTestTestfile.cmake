# CMake generated Testfile for 
# Source directory: /work/main/samplers
# Build directory: /work/main/build/samplers
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
