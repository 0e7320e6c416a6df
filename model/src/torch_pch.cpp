// The translation unit that precompiles torch/torch.h (model/CMakeLists.txt).
