// fields: being written
