# CMake generated Testfile for 
# Source directory: /work/main/plugins/optimizers
# Build directory: /work/main/build/plugins/optimizers
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
