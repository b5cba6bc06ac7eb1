/* Service wire protocol: placeholder until the levels work lands. */
#include "internal.h"
typedef int lc_service_proto_placeholder;
