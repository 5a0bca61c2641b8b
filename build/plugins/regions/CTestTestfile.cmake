# CMake generated Testfile for 
# Source directory: /work/main/plugins/regions
# Build directory: /work/main/build/plugins/regions
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
