// summary: being written
