# One kernel body, two backends.
#
# Translation units that launch kernels end in .cu. With the CUDA backend they
# are compiled by nvcc (both the CUDA kernels and the OpenMP host loops come out
# of the same source); without it they are compiled as C++ by the host
# compiler and only the OpenMP path exists.
function(lbdem_kernel_sources target)
  foreach(src IN LISTS ARGN)
    if(LBDEM_HAVE_CUDA)
      set_source_files_properties(${src} PROPERTIES LANGUAGE CUDA)
    else()
      set_source_files_properties(${src} PROPERTIES LANGUAGE CXX COMPILE_OPTIONS "-xc++")
    endif()
    target_sources(${target} PRIVATE ${src})
  endforeach()
endfunction()

# Flags every lbdem target gets.
function(lbdem_target_defaults target)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wno-unknown-pragmas>
    $<$<COMPILE_LANGUAGE:CUDA>:--expt-relaxed-constexpr -lineinfo -Xcompiler=-fopenmp -Xcompiler=-Wall --diag-suppress=20012>)
  if(LBDEM_HAVE_CUDA)
    set_target_properties(${target} PROPERTIES CUDA_SEPARABLE_COMPILATION OFF)
  endif()
endfunction()
