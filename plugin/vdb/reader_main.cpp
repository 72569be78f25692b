/// @file reader_main.cpp
/// @brief nimbus-vdb-reader: the program that reads one VDB grid for Nimbus in a process of its
///        own (see "Isolation" in vdb_reader.h). Nimbus runs it with the request on stdin and
///        reads the reply on descriptor 3; it is not meant to be run by hand.
#include "plugin/vdb/vdb_isolate.h"

int main() {
    return nimbus::vdb::detail::readerMain();
}
