/* fuzz.h: shared set-up of the libFuzzer targets (make fuzz): PETSc is
 * initialised once, errors are returned quietly (a refused input is the
 * expected outcome), and anything bigger than a modest model is skipped so
 * the fuzzer explores the parsers rather than allocating gigabytes. */
#pragma once
#include <petscsys.h>
#include <stddef.h>
#include <stdint.h>

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
  (void)argc;
  (void)argv;
  if (PetscInitializeNoArguments()) return 1;
  return PetscPushErrorHandler(PetscReturnErrorHandler, NULL) ? 1 : 0;
}
