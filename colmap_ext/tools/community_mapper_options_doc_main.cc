// Prints docs/options.md, the table of `colmap community_mapper`'s options:
//
//   build/community_mapper_options_doc > docs/options.md
#include "colmap_ext/testing/testing.h"

#include <iostream>

int main() {
  std::cout << colmap::CommunityMapperOptionsMarkdown();
  return 0;
}
