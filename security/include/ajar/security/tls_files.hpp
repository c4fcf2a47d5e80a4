// The file rule of both TLS ends (docs/security.md): ajard's network.tls files and ajar_client's
// --ca/--cert/--key (ajarctl, the console) are checked by this one function before OpenSSL reads
// them.
//
//   - the path must name a regular file (following symlinks) that can be stat'ed;
//   - a private key (`secret`) must not be accessible to group or others at all (mode & 077 == 0):
//     a key another local user can read is a stolen identity;
//   - any other file (certificate, CA, CRL) must not be writable by group or others (mode & 022
//     == 0): whoever can rewrite the CA file decides whom this end trusts.
//
// Returns "" when the file may be used, else one sentence naming the path, its mode and the fix;
// each caller prefixes what the file is (a config key, an option).
#pragma once

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

namespace ajar::security {

inline std::string tls_file_problem(const std::string& path, bool secret) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return "cannot read '" + path + "': " + std::strerror(errno);
  if (!S_ISREG(st.st_mode)) return "'" + path + "' is not a regular file";
  const unsigned mode = st.st_mode & 07777U;
  if ((mode & (secret ? 0077U : 0022U)) == 0) return {};
  char octal[8];
  std::snprintf(octal, sizeof octal, "%04o", mode);
  return "'" + path + "' has mode " + octal +
         (secret ? ": a private key must not be accessible to group or others (chmod 600; owned "
                   "by the user that reads it)"
                 : ": must not be writable by group or others (chmod 644)");
}

}  // namespace ajar::security
