/* locd accuracy: placeholder until the accuracy report lands. */
#include "cli.h"

#include <stdio.h>

int cmd_accuracy(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    fprintf(stderr, "locd: 'accuracy' (the accuracy report) is not available in this build yet\n");
    return 2;
}
