/* locd version macros: the version of the headers you compile against.
 * locd_version() reports the library actually loaded. */
#ifndef LOCD_VERSION_H
#define LOCD_VERSION_H

#define LOCD_VERSION_MAJOR 0
#define LOCD_VERSION_MINOR 1
#define LOCD_VERSION_PATCH 0
#define LOCD_VERSION_STRING "0.1.0"
#define LOCD_VERSION ((LOCD_VERSION_MAJOR << 16) | (LOCD_VERSION_MINOR << 8) | LOCD_VERSION_PATCH)

#endif
