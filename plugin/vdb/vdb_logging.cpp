/// @file vdb_logging.cpp
/// @brief initializeOpenVdb() (vdb_isolate.h): OpenVDB's logging without terminal colours.
///        libopenvdb logs through log4cplus with a layout that wraps every warning in ANSI
///        colour codes (openvdb/util/logging.h, ColoredPatternLayout); the functions that change
///        it are inline in that header and exist only with OPENVDB_USE_LOG4CPLUS, which this
///        translation unit alone defines (the other readers see OpenVDB's headers as built).
///        Its appender also wrote to stdout; this one writes to stderr.
#define OPENVDB_USE_LOG4CPLUS
#include <openvdb/openvdb.h>
#include <openvdb/util/logging.h>

#include <mutex>

#include "plugin/vdb/vdb_isolate.h"

namespace nimbus::vdb::detail {

void initializeOpenVdb() {
    static std::once_flag once;
    std::call_once(once, [] {
        openvdb::initialize();
        // OpenVDB's own set-up (logging::initialize) attaches a console appender that writes
        // to stdout, where `--progress json` writes its records: replace it by one on stderr
        log4cplus::initialize();
        log4cplus::Logger logger = openvdb::logging::internal::getLogger();
        logger.removeAppender(LOG4CPLUS_TEXT("OPENVDB"));
        log4cplus::SharedAppenderPtr appender(new log4cplus::ConsoleAppender(/*logToStdErr=*/true));
        appender->setName(LOG4CPLUS_TEXT("OPENVDB"));
        appender->setLayout(openvdb::logging::internal::ColoredPatternLayout::create("", false));
        logger.addAppender(appender);
        logger.setAdditivity(false);
        logger.setLogLevel(log4cplus::WARN_LOG_LEVEL);
    });
}

} // namespace nimbus::vdb::detail
