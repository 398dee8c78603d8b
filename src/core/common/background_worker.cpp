#include "tescalib/core/common/background_worker.h"

#include <cerrno>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace tescalib {

bool lowerThisThreadsPriority(int nice) {
#if defined(__linux__)
  if (nice <= 0) return true;
  // On Linux the nice value belongs to the thread (its kernel task id), not to the process.
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, tid);
  if (now == -1 && errno != 0) return false;
  return setpriority(PRIO_PROCESS, tid, now + nice) == 0;
#else
  return nice <= 0;
#endif
}

}  // namespace tescalib
