// files: being written
