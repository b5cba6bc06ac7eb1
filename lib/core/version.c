#include "core/core.h"

uint32_t locd_version(void)
{
    return LOCD_VERSION;
}

const char *locd_version_string(void)
{
    return LOCD_VERSION_STRING;
}
