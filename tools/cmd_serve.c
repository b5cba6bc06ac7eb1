/* locd serve: placeholder until the level-3 service lands. */
#include "cli.h"

#include <stdio.h>

int cmd_serve(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    fprintf(stderr, "locd: 'serve' (the level-3 service) is not available in this build yet\n");
    return 2;
}
