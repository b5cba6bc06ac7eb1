/* locd simulate: placeholder until the filter pipeline lands. */
#include "cli.h"

#include <stdio.h>

int cmd_simulate(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    fprintf(stderr, "locd: 'simulate' (the filter pipeline) is not available in this build yet\n");
    return 2;
}
