# vog_add_proto_library(NAME ROOT_DIR FILES...): a static library of the C++ code protoc generates
# for FILES (paths relative to ROOT_DIR, which is also the import root). Generated headers are
# included as "<dir>/<stem>.pb.h" from a SYSTEM include directory, and our warning policy is not
# applied to the generated sources (vog_target_defaults is not called on them): the code is not ours.
# Needs the protobuf::protoc and protobuf::libprotobuf targets (find_package(Protobuf)).
function(vog_add_proto_library name root_dir)
  set(generated_dir ${CMAKE_CURRENT_BINARY_DIR}/${name}_generated)
  file(MAKE_DIRECTORY ${generated_dir})
  set(generated_sources)
  foreach(proto ${ARGN})
    get_filename_component(stem ${proto} NAME_WE)
    get_filename_component(dir ${proto} DIRECTORY)
    set(cc ${generated_dir}/${dir}/${stem}.pb.cc)
    set(h ${generated_dir}/${dir}/${stem}.pb.h)
    add_custom_command(
      OUTPUT ${cc} ${h}
      COMMAND protobuf::protoc --cpp_out=${generated_dir} -I ${root_dir} ${root_dir}/${proto}
      DEPENDS ${root_dir}/${proto} protobuf::protoc
      COMMENT "protoc ${proto}")
    list(APPEND generated_sources ${cc})
  endforeach()
  add_library(${name} STATIC ${generated_sources})
  target_include_directories(${name} SYSTEM PUBLIC ${generated_dir})
  target_link_libraries(${name} PUBLIC protobuf::libprotobuf)
  target_compile_features(${name} PUBLIC cxx_std_20)
  set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()
