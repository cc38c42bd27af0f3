"""Small pure numpy/scipy kernels shared by the stages."""
